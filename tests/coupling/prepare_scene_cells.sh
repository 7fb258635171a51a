#!/usr/bin/env bash
# Test fixture: one small prepared unit cell (100 spheres) in DIR under every
# name a shipped GMH scene reads (`file: NAME.ckpt` in configs/gmh), so each
# scene can be set up from DIR. Usage: prepare_scene_cells.sh BIN_DIR CONFIG_DIR DIR
set -euo pipefail
bin=$1 configs=$2 dir=$3
mkdir -p "$dir"
"$bin/dem_prepare_cell" --out "$dir/cell100" --count 100 --seed 1 > "$dir/cell100.log"
for name in $(grep -ohE 'file: [A-Za-z0-9_]+\.ckpt' "$configs"/gmh/*.yaml | sed 's/file: //; s/\.ckpt$//' | sort -u); do
  ln -sf cell100.ckpt "$dir/$name.ckpt"
  ln -sf cell100.h5 "$dir/$name.h5"
done
