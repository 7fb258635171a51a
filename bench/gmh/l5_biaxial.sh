#!/usr/bin/env bash
# Scene L5, reduced (Liu, Sun, Fish 2016 Sec. 3.5): prepares an undamped unit
# cell (dem_prepare_cell --damping 0, Liu's Table I for this section), runs
# configs/gmh/l5_biaxial.yaml on three meshes, each local and nonlocal
# (nonlocal: {radius: 6.75e-3, local_fraction: beta}: Liu's 2R = 13.5 mm, and
# beta = 0.15 of each point's own increment, without which the bell kernel is
# indefinite on the 12x24 mesh; docs/gmh_unit_cells.md), mesh by mesh, and prints
# the stress-strain curves, the band widths and the post-peak spread of the
# meshes per mode (bench/gmh/l5_biaxial.py, /usr/bin/python3 with h5py and
# matplotlib; figure l5_biaxial.png in the work folder).
# Usage: bench/gmh/l5_biaxial.sh [spheres per cell (200)] [coarse steps (4000)] [meshes ("6x12 8x16 12x24")]
#                                [modes ("local nonlocal"; also "inelastic")]
# The top moves at the scene's 0.1 m/s (1.25e-5 axial strain per step of 1e-5 s: 4000
# steps to 5 %) unless L5_TOP_VELOCITY [m/s] says otherwise; the step count sets how far
# the run goes.
# A run that stops early (a cell over its relaxation budget) is still analysed up to where it got.
# Environment: COSIM_BIN (default build/bin), L5_WORK (default a fresh /tmp dir),
# L5_LOCAL_FRACTION (beta of the nonlocal runs, default 0.15), L5_RADIUS (R of the
# nonlocal runs [m], default 6.75e-3), L5_VARIANTS (0)
# N more cells prepared with seeds 2 .. N + 1, each element's cell picked from
# the N + 1 by its id (unit_cells.variants), L5_ON_FAILURE (stop) the workers'
# on_failure, L5_MAX_STEPS (the scene's 200000) their relaxation budget,
# L5_STRESS_FREE=PRESSURE,AFTER their stress_free_exit (e.g. 400,2000: a job
# whose cell is below 400 Pa mean stress and unrelaxed after 2000 steps ends
# there, failed), L5_TOP_VELOCITY the top's speed [m/s] (the scene's 0.1; the
# specimen starts in the matching homogeneous compression, v_y = -V y / H), and
# L5_LOAD_STEPS the DEM steps over which each increment is applied (the scene's 5;
# docs/gmh_unit_cells.md "Quasi-static loading"),
# and L5_HOURGLASS the one-point elements' hourglass coefficient kappa (the scene's 0.005;
# fem_solver's default 0.05 is stiffer than the cells past their plateau, docs/gmh_unit_cells.md).
# Mode "inelastic" averages the cells' inelastic stress instead of the strain increments
# (nonlocal: {radius: L5_INELASTIC_RADIUS (13.5e-3: h <= R/2 on every mesh), averages: inelastic_stress,
# over_nonlocal: L5_OVER_NONLOCAL (0.15), stiffness: {E: L5_STIFFNESS_E, nu: L5_STIFFNESS_NU}}, defaults
# 7.56e8 Pa and 0.113 (L1's 500-sphere cell); docs/gmh_unit_cells.md).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
bin=${COSIM_BIN:-$root/build/bin}
count=${1:-200}
steps=${2:-4000}
meshes=${3:-6x12 8x16 12x24}
modes=${4:-local nonlocal}
beta=${L5_LOCAL_FRACTION:-0.15}
radius=${L5_RADIUS:-6.75e-3}
number='^[0-9.]+([eE][+-]?[0-9]+)?$'
[[ "$radius" =~ $number ]] || { echo "l5_biaxial.sh: L5_RADIUS must be a length in m (got '$radius')" >&2; exit 2; }
for mesh in $meshes; do
  [[ $mesh =~ ^[1-9][0-9]*x[1-9][0-9]*$ ]] || { echo "l5_biaxial.sh: mesh '$mesh' is not NXxNY (e.g. 8x16)" >&2; exit 2; }
done
for mode in $modes; do
  [[ $mode == local || $mode == nonlocal || $mode == inelastic ]] ||
    { echo "l5_biaxial.sh: mode '$mode' is not local, nonlocal or inelastic" >&2; exit 2; }
done
[[ -z "${L5_STRESS_FREE:-}" || "$L5_STRESS_FREE" =~ ^[0-9.eE+-]+,[0-9]+$ ]] ||
  { echo "l5_biaxial.sh: L5_STRESS_FREE must be PRESSURE,AFTER (e.g. 400,2000; got '$L5_STRESS_FREE')" >&2; exit 2; }
[[ -z "${L5_TOP_VELOCITY:-}" || "$L5_TOP_VELOCITY" =~ $number ]] ||
  { echo "l5_biaxial.sh: L5_TOP_VELOCITY must be a speed in m/s (got '$L5_TOP_VELOCITY')" >&2; exit 2; }
[[ -z "${L5_LOAD_STEPS:-}" || "$L5_LOAD_STEPS" =~ ^[1-9][0-9]*$ ]] ||
  { echo "l5_biaxial.sh: L5_LOAD_STEPS must be a whole number >= 1 (got '$L5_LOAD_STEPS')" >&2; exit 2; }
over_nonlocal=${L5_OVER_NONLOCAL:-0.15}
inelastic_radius=${L5_INELASTIC_RADIUS:-13.5e-3}
stiffness_e=${L5_STIFFNESS_E:-7.56e8}
stiffness_nu=${L5_STIFFNESS_NU:-0.113}
for v in inelastic_radius over_nonlocal stiffness_e stiffness_nu; do
  [[ "${!v}" =~ $number ]] || { echo "l5_biaxial.sh: L5_${v^^} must be a number >= 0 (got '${!v}')" >&2; exit 2; }
done
[[ -z "${L5_HOURGLASS:-}" || "$L5_HOURGLASS" =~ $number ]] ||
  { echo "l5_biaxial.sh: L5_HOURGLASS must be a coefficient >= 0 (got '$L5_HOURGLASS')" >&2; exit 2; }
loading=()
if [[ -n "${L5_TOP_VELOCITY:-}" ]]; then
  height=0.08  # configs/gmh/l5_biaxial.yaml: the specimen's 80 mm; boundary[3] is its top
  loading=(--set "solvers.block.params.boundary[3].value=-$L5_TOP_VELOCITY"
           --set "solvers.block.params.initial_velocity={gradient: {y: [0, $(/usr/bin/python3 -c "print(-$L5_TOP_VELOCITY / $height)"), 0]}}")
fi
work=${L5_WORK:-$(mktemp -d /tmp/gmh-l5.XXXXXX)}
mkdir -p "$work"
source "$root/bench/gmh/gmh_scene.sh"
gmh_prepare_cell "$count" --damping 0
variants=()
if [[ "${L5_VARIANTS:-0}" != 0 ]]; then
  [[ "$L5_VARIANTS" =~ ^[1-9][0-9]*$ ]] || { echo "l5_biaxial.sh: L5_VARIANTS must be a whole number (got '$L5_VARIANTS')" >&2; exit 2; }
  list=$(gmh_prepare_variants "$count" "$L5_VARIANTS" --damping 0)
  variants=(--set "solvers.cells_a.params.unit_cells.variants=$list" --set "solvers.cells_b.params.unit_cells.variants=$list")
fi
runs=()
for mesh in $meshes; do
  nx=${mesh%x*}
  ny=${mesh#*x}
  cells=$((nx * ny))
  half=$(((cells + 1) / 2))  # cells_a: the even ids, cells_b: the odd ones (stride 2)
  for mode in $modes; do
    extra=()
    [[ $mode == nonlocal ]] && extra=(--set "couplings.cells.nonlocal={radius: $radius, local_fraction: $beta}")
    [[ $mode == inelastic ]] && extra=(--set "couplings.cells.nonlocal={radius: $inelastic_radius, averages: inelastic_stress,
      over_nonlocal: $over_nonlocal, stiffness: {E: $stiffness_e, nu: $stiffness_nu}}")
    echo "== $mode $mesh ($cells cells)"
    t0=$(date +%s)
    gmh_run "$root/configs/gmh/l5_biaxial.yaml" --set "schedule.coarse_steps=$steps" \
      --set "solvers.block.params.mesh.box.divisions=[$nx, $ny, 1]" \
      --set "solvers.cells_a.params.unit_cells.count=$half" \
      --set "solvers.cells_b.params.unit_cells.count=$((cells - half))" \
      --set "solvers.cells_a.params.unit_cells.file=$work/cell.ckpt" \
      --set "solvers.cells_b.params.unit_cells.file=$work/cell.ckpt" "${extra[@]}" "${variants[@]}" \
      ${L5_ON_FAILURE:+--set "solvers.cells_a.params.unit_cells.on_failure=$L5_ON_FAILURE"} \
      ${L5_ON_FAILURE:+--set "solvers.cells_b.params.unit_cells.on_failure=$L5_ON_FAILURE"} \
      "${loading[@]}" ${L5_HOURGLASS:+--set "solvers.block.params.hourglass=$L5_HOURGLASS"} \
      ${L5_LOAD_STEPS:+--set "solvers.cells_a.params.unit_cells.load_steps=$L5_LOAD_STEPS"} \
      ${L5_LOAD_STEPS:+--set "solvers.cells_b.params.unit_cells.load_steps=$L5_LOAD_STEPS"} \
      ${L5_MAX_STEPS:+--set "solvers.cells_a.params.unit_cells.max_steps=$L5_MAX_STEPS"} \
      ${L5_MAX_STEPS:+--set "solvers.cells_b.params.unit_cells.max_steps=$L5_MAX_STEPS"} \
      ${L5_STRESS_FREE:+--set "solvers.cells_a.params.unit_cells.stress_free_exit={pressure: ${L5_STRESS_FREE%,*}, after: ${L5_STRESS_FREE#*,}}"} \
      ${L5_STRESS_FREE:+--set "solvers.cells_b.params.unit_cells.stress_free_exit={pressure: ${L5_STRESS_FREE%,*}, after: ${L5_STRESS_FREE#*,}}"}
    rm -rf "${work:?}/$mode-$mesh"  # a reused L5_WORK: mv would nest the new run inside the old one
    mv "$work/run" "$work/$mode-$mesh"
    mv "$work/run.log" "$work/$mode-$mesh.log"
    echo "($mode $mesh: $(($(date +%s) - t0)) s)"
    runs+=("$mode:$mesh=$work/$mode-$mesh")
  done
done
/usr/bin/python3 "$root/bench/gmh/l5_biaxial.py" "${runs[@]}" --png "$work/l5_biaxial.png"
echo "(files in $work)"
