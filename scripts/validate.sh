#!/usr/bin/env bash
# Runs the validation scenes of validation/scenes/ and writes the report:
#   scripts/validate.sh [--tier quick|standard|full] [--jobs N] [SCENE ...]
# quick (inside scripts/test.sh, a few minutes): short windows checked against
#   analytic values and reference runs; report in runs/validation/quick/.
# standard (the default): every scene as configured; writes validation/report.md,
#   report.json and figures/, and the validation tables of README.md and docs/.
# full: standard plus the paper-size and paper-condition variants.
# Builds first (scripts/setup.sh) unless --no-build or COSIM_BIN names the binaries.
# Exit status: 0 when no figure deviates, 1 when one does, 2 for bad usage.
set -euo pipefail
cd "$(dirname "$0")/.."
args=()
build=1
for a in "$@"; do
  case $a in
    --no-build) build=0 ;;
    *) args+=("$a") ;;
  esac
done
if [ -z "${COSIM_BIN:-}" ] && [ $build = 1 ]; then
  ./scripts/setup.sh
fi
exec /usr/bin/python3 validation/validate.py --bin "${COSIM_BIN:-build/bin}" "${args[@]}"
