#!/usr/bin/env bash
# Same lattice, same model, two codes: LAMMPS peri/pmb and peri/lps (Debian's
# `lammps` package, `apt-get install lammps`) against pd_solver's pmb and lps
# as run by pd_bench --lammps-rules (LAMMPS' partial-volume rule and its LPS
# influence function 1/|xi|). Unit lattice N^3, horizon 3 spacings, E = 1,
# nu = 0.25, rho = 1, a 1e-3 velocity pulse in the 4 x 4 x 4 corner, fixed
# steps at dt = dt_crit / 2. Prints node-steps/s of both codes with 1 and 2
# ranks/threads, their ratio, and the largest difference of the probe
# particle's displacement history, relative to its peak, which must stay
# below 1 %.
#
# Measured with Debian's LAMMPS 29 Sep 2021: peri/pmb agrees with pd_solver
# to 1e-12 over the whole run. peri/lps agrees for the first two steps and
# then departs (~13 % of the probe peak) because that LAMMPS version marks
# bonds broken in the first step even with s00 = 1e10 (compute damage/atom
# sums to 0.0026 after step 1, for any s00; peri/pmb shows 0); re-evaluating
# LAMMPS' own step-2 configuration from scratch (read_dump + run 0) gives
# pd_solver's forces to 12 digits. So the LPS probe check fails for a
# reason on the LAMMPS side; the throughput comparison stands.
#   bench/pd/lammps_compare.sh [BUILD_DIR] [SIZES]   (default build, "20 40")
# Installs Debian's lammps package when `lmp` is missing.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$root/build}
sizes=${2:-"20 40"}
bench=$build/bin/pd_bench
if ! command -v lmp > /dev/null; then
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  echo "installing Debian's lammps package" >&2
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq lammps > /dev/null
fi
[ -x "$bench" ] || { echo "$bench not built (ninja -C $build pd_bench)" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

dt=$("$bench" --sizes 4 --threads 1 --models pmb --steps-20 1 --probe | awk '/^dt/ {print $2}')
K=$(awk 'BEGIN {printf "%.17g", 1.0 / (3.0 * (1.0 - 2.0 * 0.25))}')
G=$(awk 'BEGIN {printf "%.17g", 1.0 / (2.0 * (1.0 + 0.25))}')
c=$(awk -v k="$K" 'BEGIN {printf "%.17g", 18.0 * k / (3.14159265358979323846 * 81.0)}')

lammps_input() {  # model n steps
  local model=$1 n=$2 steps=$3 coeff
  if [ "$model" = pmb ]; then coeff="$c 3.0 1.0e10 0.0"; else coeff="$K $G 3.0 1.0e10 0.0"; fi
  cat <<IN
units lj
atom_style peri
atom_modify map array
boundary s s s
lattice sc 1.0
region box block -0.5 $((n - 1)).5 -0.5 $((n - 1)).5 -0.5 $((n - 1)).5
create_box 1 box
create_atoms 1 region box
pair_style peri/$model
pair_coeff * * $coeff
set group all density 1.0
set group all volume 1.0
region pulse block -0.1 3.1 -0.1 3.1 -0.1 3.1 units box
group pulse region pulse
velocity pulse set 1.0e-3 0.0 0.0 units box
region probe block 5.9 6.1 0.9 1.1 0.9 1.1 units box
group probe region probe
compute d probe displace/atom
compute px probe reduce sum c_d[1]
variable ux equal c_px
variable st equal step
fix out all print 10 "probe \${st} \${ux}" file probe.txt screen no
fix integrate all nve
timestep $dt
thermo 0
run $steps
IN
}

printf "%-6s %-4s %-6s %-16s %-16s %-8s %-12s\n" model N ranks lammps_nsps pd_solver_nsps ratio probe_diff
for model in pmb lps; do
  for n in $sizes; do
    steps=$(awk -v n="$n" 'BEGIN {s = int(200 * 8000 / (n * n * n)); if (s < 5) s = 5; print s}')
    # pd_solver probe history (1 thread) and throughput.
    "$bench" --sizes "$n" --threads 1 --models "$model" --lammps-rules --probe > "$work/pd_probe.txt"
    for ranks in 1 2; do
      dir=$work/$model-$n-$ranks
      mkdir -p "$dir"
      lammps_input "$model" "$n" "$steps" > "$dir/in.peri"
      # Best of 3 LAMMPS runs as well.
      lnsps=0
      for rep in 1 2 3; do
        if [ "$ranks" = 1 ]; then
          (cd "$dir" && lmp -in in.peri -log log.lammps -screen none)
        else
          (cd "$dir" && mpirun --allow-run-as-root --oversubscribe -np 2 lmp -in in.peri -log log.lammps -screen none)
        fi
        lnsps=$(awk -v best="$lnsps" '/^Loop time of/ {v = $12 * $9 / $4; print (v > best) ? v : best}' "$dir/log.lammps")
      done
      pnsps=$("$bench" --sizes "$n" --threads "$ranks" --models "$model" --lammps-rules --repeat 3 | awk 'NR == 2 {print $6}')
      diff=$(awk 'FNR == NR {if ($1 == "probe") p[$4] = $5; next}
                  $1 == "probe" && ($2 in p) {d = $3 - p[$2]; if (d < 0) d = -d; if (d > m) m = d;
                                               a = ($3 < 0) ? -$3 : $3; if (a > peak) peak = a}
                  END {r = (peak > 0) ? m / peak : -1; printf "%.2e", r}' "$work/pd_probe.txt" "$dir/probe.txt")
      ratio=$(awk -v a="$pnsps" -v b="$lnsps" 'BEGIN {printf "%.2f", a / b}')
      printf "%-6s %-4s %-6s %-16.4g %-16.4g %-8s %-12s\n" "$model" "$n" "$ranks" "$lnsps" "$pnsps" "$ratio" "$diff"
    done
  done
done
