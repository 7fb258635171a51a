#!/usr/bin/env bash
# Installs what is missing (Debian packages only) and builds Release into build/.
# Idempotent and quiet when everything is there. Environment:
#   COSIM_BUILD_DIR (default build), COSIM_WERROR=ON to treat warnings as errors,
#   COSIM_CMAKE_ARGS more configure arguments (scripts/sanitize.sh: the sanitizers).
set -euo pipefail
cd "$(dirname "$0")/.."

# libsuitesparse-dev: CHOLMOD, the FEM's supernodal direct solver;
# libopenblas0-openmp: an optimised BLAS for it (Debian's alternatives make it
# libblas.so.3; the reference BLAS makes the factorisation several times slower).
packages=(build-essential cmake ninja-build pkg-config
          libeigen3-dev libzmq3-dev cppzmq-dev capnproto libcapnp-dev
          libhdf5-dev libyaml-cpp-dev libgtest-dev nlohmann-json3-dev libsuitesparse-dev libopenblas0-openmp
          python3-numpy python3-h5py python3-matplotlib python3-yaml)
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
# COSIM_WERROR is passed only when set, so running the default scene after the
# tests does not flip the warning flags and rebuild everything.
werror=()
[ -n "${COSIM_WERROR:-}" ] && werror=(-DCOSIM_WERROR="$COSIM_WERROR")
read -r -a extra <<< "${COSIM_CMAKE_ARGS:-}"
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release "${werror[@]}" "${extra[@]}" >/dev/null
# Progress lines are dropped; warnings, errors and a failed build are not.
set +e
cmake --build "$build_dir" -j "$jobs" 2>&1 | grep -vE '^\[[0-9]+/[0-9]+\] '
status=${PIPESTATUS[0]}
set -e
if [ "$status" -ne 0 ]; then
  echo "setup: the build failed (see above)" >&2
  exit "$status"
fi
