#!/usr/bin/env bash
# fem_solver against CalculiX (Debian's calculix-ccx) on scene C1's beam:
# the 0.8 x 0.8 x 12 m cantilever, E = 1e8 Pa, nu = 0, clamped at y = 0, a
# 100 N tip load as a uniform traction on the end face. Same mesh, same
# consistent nodal loads; CalculiX C3D8I (incompatible modes) and C3D8 (full
# integration) in a geometrically linear static step, against fem_solver's
# incompatible-modes and full hexahedra in its linear static analysis
# (integrator linear: true, K_0 u = f with the default direct solver).
# For every mesh and element: free dofs, the mean tip deflection of both
# codes and their relative difference, each code's wall and CPU time, and the
# wall-time ratio fem_solver / CalculiX. fem_solver's time includes the
# coupler, process start-up and HDF5 output; CalculiX's its input parsing and
# .frd/.dat output.
#   bench/fem/calculix_compare.sh [BUILD_DIR] [MESH ...]
# MESH is "nx ny nz"; default "2 30 2" "8 120 8" "10 300 10" (810, 29160 and
# 108900 free dofs). Installs Debian's calculix-ccx package when `ccx` is missing.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
shift || true
meshes=("$@")
[ ${#meshes[@]} -gt 0 ] || meshes=("2 30 2" "8 120 8" "10 300 10")
if ! command -v ccx > /dev/null; then
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  echo "installing Debian's calculix-ccx package" >&2
  $sudo apt-get install -y -qq calculix-ccx > /dev/null
fi
# OpenBLAS 0.3.21 (Debian 12; CHOLMOD's BLAS once libopenblas0 is installed)
# does not recognise CPUs newer than itself (the development VM's Xeon, family
# 6 model 207) and falls back to generic Prescott kernels, which nearly
# doubles the factorisation time; its SkylakeX kernels run on any AVX-512 CPU.
if [ -z "${OPENBLAS_CORETYPE:-}" ] && grep -qw avx512f /proc/cpuinfo; then export OPENBLAS_CORETYPE=SkylakeX; fi
work=$(mktemp -d /tmp/ccx-compare.XXXXXX)
cd "$work"

# --- CalculiX inputs: nodes on the box grid, C3D8(I) in Abaqus node order,
# consistent nodal forces of the 156.25 Pa end-face traction (bilinear faces).
write_ccx_inputs() {  # nx ny nz
/usr/bin/python3 - "$1" "$2" "$3" <<'PY'
import sys
nx, ny, nz = map(int, sys.argv[1:])
X0, X1, Y1, Z1, traction = -0.4, 0.4, 12.0, 0.8, -156.25
def nid(i, j, k): return 1 + i + (nx + 1) * (j + (ny + 1) * k)
nodes = []
for k in range(nz + 1):
    for j in range(ny + 1):
        for i in range(nx + 1):
            nodes.append((nid(i, j, k), X0 + (X1 - X0) * i / nx, Y1 * j / ny, Z1 * k / nz))
elements = []
for k in range(nz):
    for j in range(ny):
        for i in range(nx):
            elements.append([nid(i, j, k), nid(i + 1, j, k), nid(i + 1, j + 1, k), nid(i, j + 1, k),
                             nid(i, j, k + 1), nid(i + 1, j, k + 1), nid(i + 1, j + 1, k + 1), nid(i, j + 1, k + 1)])
area = (X1 - X0) / nx * Z1 / nz
loads = {}
for k in range(nz):
    for i in range(nx):
        for (a, b) in ((i, k), (i + 1, k), (i + 1, k + 1), (i, k + 1)):
            n = nid(a, ny, b)
            loads[n] = loads.get(n, 0.0) + traction * area / 4.0
for etype in ("C3D8I", "C3D8"):
    with open(f"cant_{etype}.inp", "w") as f:
        f.write("*NODE\n")
        for n in nodes: f.write(f"{n[0]}, {n[1]:.12g}, {n[2]:.12g}, {n[3]:.12g}\n")
        f.write(f"*ELEMENT, TYPE={etype}, ELSET=EALL\n")
        for e, c in enumerate(elements, 1): f.write(f"{e}, " + ", ".join(map(str, c)) + "\n")
        f.write("*NSET, NSET=CLAMP\n")
        f.write("\n".join(str(nid(i, 0, k)) for k in range(nz + 1) for i in range(nx + 1)) + "\n")
        f.write("*NSET, NSET=TIP\n")
        f.write("\n".join(str(nid(i, ny, k)) for k in range(nz + 1) for i in range(nx + 1)) + "\n")
        f.write("*MATERIAL, NAME=BEAM\n*ELASTIC\n1.0e8, 0.0\n*DENSITY\n1309.\n")
        f.write("*SOLID SECTION, ELSET=EALL, MATERIAL=BEAM\n")
        f.write("*BOUNDARY\nCLAMP, 1, 3, 0.\n")
        f.write("*STEP\n*STATIC\n*CLOAD\n")
        for n, v in sorted(loads.items()): f.write(f"{n}, 3, {v:.12g}\n")
        f.write("*NODE PRINT, NSET=TIP\nU\n*END STEP\n")
PY
}

tip_ccx() {  # mean U3 of the TIP nodes from the .dat file
  /usr/bin/python3 - "$1" <<'PY'
import sys
vals, on = [], False
for line in open(sys.argv[1]):
    if "displacements" in line: on = True; continue
    parts = line.split()
    if on and len(parts) == 4:
        try: vals.append(float(parts[3]))
        except ValueError: pass
print(sum(vals) / len(vals))
PY
}
tip_fem() {  # mean z displacement of the ymax nodes in the last snapshot of beam.h5
  /usr/bin/python3 - "$1" <<'PY'
import sys, h5py, numpy as np
f = h5py.File(sys.argv[1], "r")
x = f["/mesh/coordinates"][:].reshape(-1, 3)
last = sorted(f["/snapshots"].keys(), key=int)[-1]
u = f[f"/snapshots/{last}/displacement"][:].reshape(-1, 3)
tip = np.isclose(x[:, 1], x[:, 1].max())
print(u[tip, 2].mean())
PY
}
# Runs a command with its output in a log file; prints "wall cpu" in seconds
# (cpu: user + system of the command and its children).
timed() {  # log command...
  /usr/bin/python3 - "$@" <<'PY'
import resource, subprocess, sys, time
log, cmd = sys.argv[1], sys.argv[2:]
t0 = time.monotonic()
with open(log, "w") as out:
    rc = subprocess.call(cmd, stdout=out, stderr=subprocess.STDOUT)
wall = time.monotonic() - t0
r = resource.getrusage(resource.RUSAGE_CHILDREN)
if rc != 0:
    sys.exit(f"{' '.join(cmd)} failed ({rc}); see {log}")
print(f"{wall:.3f} {r.ru_utime + r.ru_stime:.3f}")
PY
}

timo=$(python3 -c "P=100; L=12; E=1e8; I=0.8**4/12; A=0.64; G=E/2; k=5/6; print(-(P*L**3/(3*E*I) + P*L/(k*G*A)))")
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg); $(nproc) cores; OMP_NUM_THREADS=${OMP_NUM_THREADS:-unset};" \
  "BLAS: $(readlink -f /usr/lib/x86_64-linux-gnu/libblas.so.3 2>/dev/null || echo unknown), OPENBLAS_CORETYPE=${OPENBLAS_CORETYPE:-unset}"
printf "%-10s %7s %-20s %-14s %-14s %-9s %8s %8s %8s %8s %7s\n" "mesh" "dofs" "formulation" "fem_solver [m]" \
  "CalculiX [m]" "diff" "fem [s]" "ccx [s]" "fem cpu" "ccx cpu" "fem/ccx"
for mesh in "${meshes[@]}"; do
  read -r nx ny nz <<< "$mesh"
  write_ccx_inputs "$nx" "$ny" "$nz"
  dofs=$((3 * (nx + 1) * (nz + 1) * ny))
  for pair in "incompatible-modes:C3D8I" "full:C3D8"; do
    form=${pair%%:*}; etype=${pair##*:}
    read -r ccx_wall ccx_cpu <<< "$(timed "ccx_$etype.log" ccx -i "cant_$etype")"
    c=$(tip_ccx "cant_$etype.dat")
    out="$work/fem_${form}_${nx}x${ny}x${nz}"
    read -r fem_wall fem_cpu <<< "$(timed "$out.log" "$build/bin/coupler" run "$root/configs/fem/cantilever_static.yaml" \
      --out "$out" --no-progress --set solvers.beam.params.formulation="$form" \
      --set "solvers.beam.params.mesh.box.divisions=[$nx, $ny, $nz]" --set solvers.beam.params.integrator.linear=true)"
    f=$(tip_fem "$out/beam.h5")
    python3 -c "import sys; f, c, fw, cw, fc, cc = map(float, sys.argv[1:7]); print(f'{sys.argv[7]:<10s} {int(sys.argv[8]):7d} {sys.argv[9]:<20s} {f:<14.6e} {c:<14.6e} {abs(f - c) / abs(c):<9.1e} {fw:8.2f} {cw:8.2f} {fc:8.2f} {cc:8.2f} {fw / cw:7.2f}')" \
      "$f" "$c" "$fem_wall" "$ccx_wall" "$fem_cpu" "$ccx_cpu" "${nx}x${ny}x${nz}" "$dofs" "$form"
  done
done
echo "Timoshenko (shear factor 5/6): $timo m; runs in $work"
