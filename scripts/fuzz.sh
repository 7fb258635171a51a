#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ with clang (build-fuzz/, address and
# undefined sanitizers, leak checks) and runs each from its seed corpus for
# RUNS executions (default 1000000), one worker. New inputs that reach new
# code go to build-fuzz/corpus/<target>; crashes, leaks and timeouts are
# written to build-fuzz/findings/<target>/ and make the script exit 1.
# Usage: scripts/fuzz.sh [RUNS] [TARGET ...]   (targets: fuzz/CMakeLists.txt)
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-1000000}
shift || true
command -v clang++ >/dev/null || { echo "fuzz.sh: needs clang (apt-get install clang)" >&2; exit 2; }
cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang \
  -DCMAKE_CXX_COMPILER=clang++ -DCOSIM_FUZZ=ON -DCOSIM_SANITIZE=address,undefined -DCOSIM_BUILD_TESTS=OFF \
  -DCOSIM_BUILD_BENCH=OFF -DCOSIM_SOLVERS='dem;fem;pd' >/dev/null
targets=("$@")
[[ ${#targets[@]} -gt 0 ]] || mapfile -t targets < <(sed -n 's/^set(COSIM_FUZZ_TARGETS \(.*\))$/\1/p' fuzz/CMakeLists.txt | tr ' ' '\n')
status=0
for t in "${targets[@]}"; do
  cmake --build build-fuzz --target "fuzz_$t" >/dev/null
  mkdir -p "build-fuzz/corpus/$t" "build-fuzz/findings/$t"
  echo "== $t: $runs executions"
  if ! build-fuzz/bin/"fuzz_$t" -runs="$runs" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
       -artifact_prefix="build-fuzz/findings/$t/" "build-fuzz/corpus/$t" "fuzz/corpus/$t" 2>&1 |
       grep -E "^#[0-9]+[[:space:]]+(DONE|INITED)|stat::|ERROR|SUMMARY|Test unit written"; then
    :
  fi
  if compgen -G "build-fuzz/findings/$t/*" >/dev/null; then
    echo "$t: findings in build-fuzz/findings/$t/" >&2
    status=1
  fi
done
exit $status
