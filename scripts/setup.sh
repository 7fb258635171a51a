#!/usr/bin/env bash
# Installs what is missing (Debian packages only) and builds Release into build/.
# Idempotent and quiet when everything is there. Environment:
#   COSIM_BUILD_DIR (default build), COSIM_WERROR=ON to treat warnings as errors.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(build-essential cmake ninja-build pkg-config
          libeigen3-dev libzmq3-dev cppzmq-dev capnproto libcapnp-dev
          libhdf5-dev libyaml-cpp-dev libgtest-dev nlohmann-json3-dev
          python3-numpy python3-h5py python3-matplotlib)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

build_dir=${COSIM_BUILD_DIR:-build}
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DCOSIM_WERROR="${COSIM_WERROR:-OFF}" >/dev/null
cmake --build "$build_dir" -j "$jobs" | grep -vE '^\[[0-9]+/[0-9]+\] ' || true
test "${PIPESTATUS[0]}" -eq 0
