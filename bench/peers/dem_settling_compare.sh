#!/usr/bin/env bash
# dem_solver against LIGGGHTS (Debian's `liggghts`, 3.8.0) and LAMMPS
# (Debian's `lammps`, GRANULAR package) on the settling scene of
# configs/dem/settling.yaml: monodisperse glass spheres (d = 2 mm, 2500 kg/m^3,
# E = 5e7 Pa, nu = 0.25, e = 0.5, mu = 0.5) on a jittered cubic lattice
# (spacing 2.4 mm) in a box of five plane walls, Hertz-Mindlin with history,
# gravity -9.81 z, dt = 5e-6 s, skin 0.2 mm, velocity Verlet (nve/sphere).
#
# All three codes start from the same positions: dem_settling_bench --data
# writes its jittered lattice as a LAMMPS data file that LAMMPS and LIGGGHTS
# read. Contact history cannot be carried across codes, so each code settles
# the same number of untimed steps, then runs the same number of timed steps.
#   dense:  N = 8000,  settle DENSE_SETTLE (20000) steps, time DENSE_STEPS (2000)
#   dilute: N = 64000, settle DILUTE_SETTLE (4000) steps, time DILUTE_STEPS (1000)
# on 1 and 2 threads (THREADS="1 2"). Prints particle-steps per second (wall
# time of the timed steps; CPU time of all the code's processes over them) and
# the end state: kinetic energy (translational + rotational), coordination
# number 2C/N (particle pairs only) and packing height max(z + r).
#
# Contact parameters, mapped to dem_solver's law F_n = 4/3 E* sqrt(R*) u^(3/2)
# - gamma sqrt(S_n m*) v_n, S_n = 2 E* sqrt(R* u), F_t = -k_t s - gamma
# sqrt(k_t m*) v_t, k_t = 8 G* sqrt(R* u), |F_t| <= mu |F_n| (gamma calibrated
# to e = 0.5 exactly; the bench prints it):
#   LIGGGHTS model hertz: gamma_n = 2 sqrt(5/6) beta sqrt(S_n m*), beta =
#     -ln e / sqrt(ln^2 e + pi^2), same form for the tangential dashpot; its
#     coefficientRestitution is the e whose beta gives dem_solver's gamma
#     (they agree to 1e-6 at e = 0.5).
#   LAMMPS granular hertz/material + damping tsuji: eta_n = alpha(e) sqrt(m* k_n)
#     with k_n = 4/3 E* a = 2/3 S_n and Tsuji's polynomial alpha(e), so its
#     e is solved from alpha(e) = gamma sqrt(3/2); tangential mindlin NULL
#     (k_t = 8 G* a) with eta_t = x_gamma_t eta_n, x_gamma_t = sqrt(k_t/S_n) =
#     sqrt(4 G*/E*), which makes the tangential dashpot dem_solver's.
# Residual differences: LIGGGHTS tests the Coulomb limit on the spring force
# alone and drops the tangential dashpot while sliding; LAMMPS rotates the
# stored shear into the tangent plane only when it points along +n; both take
# the radius, dem_solver r - u/2, as the lever arm of the contact point.
# 2 threads: dem_solver with OpenMP; LAMMPS and LIGGGHTS as 2 MPI ranks
# (mpirun; Debian's LAMMPS has no OPENMP package, LIGGGHTS no OpenMP), the
# box split in x or y (processors * * 1) so both ranks hold half the packing.
# Takes about 2 minutes on 2 cores (more when other jobs load them).
# REPEAT=N runs every code N times per case and keeps its fastest run (each
# settles anew; the end state printed is that run's): on a shared or
# virtual machine one run can be slowed by something else, and the best of a
# few is the figure that repeats.
#
#   bench/peers/dem_settling_compare.sh [BUILD_DIR]
# Installs Debian's liggghts and lammps packages when missing.
set -uo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=$(cd "${1:-$root/build}" && pwd)
bench=$build/bin/dem_settling_bench
dense_settle=${DENSE_SETTLE:-20000}
dense_steps=${DENSE_STEPS:-2000}
dilute_settle=${DILUTE_SETTLE:-4000}
dilute_steps=${DILUTE_STEPS:-1000}
threads=${THREADS:-"1 2"}
repeat=${REPEAT:-1}
[[ "$repeat" =~ ^[1-9][0-9]*$ ]] || { echo "dem_settling_compare.sh: REPEAT must be a whole number >= 1 (got '$repeat')" >&2; exit 2; }
[ -x "$bench" ] || { echo "$bench not built (cmake --build $build --target dem_settling_bench)" >&2; exit 2; }
for pkg in liggghts:liggghts lmp:lammps; do
  if ! command -v "${pkg%%:*}" > /dev/null; then
    sudo=""
    [ "$(id -u)" -ne 0 ] && sudo="sudo"
    echo "installing Debian's ${pkg#*:} package" >&2
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq "${pkg#*:}" > /dev/null
  fi
done
work=$(mktemp -d /tmp/dem-compare.XXXXXX)
trap 'rm -rf "$work"' EXIT
cd "$work"
mpi=(mpirun --allow-run-as-root --oversubscribe -np 2)
export OMPI_MCA_btl_vader_single_copy_mechanism=none  # quiet in containers

# CPU seconds (user + system) of the calling LAMMPS/LIGGGHTS process, or of
# all ranks when mpirun started it; called through the codes' `shell` command.
cat > cpu.sh <<'SH'
pid=$$
while [ "$pid" -gt 1 ]; do
  case "$(cat /proc/$pid/comm)" in lmp|liggghts) break ;; esac
  pid=$(awk '{print $4}' /proc/$pid/stat)
done
parent=$(awk '{print $4}' /proc/$pid/stat)
pids=$pid
case "$(cat /proc/$parent/comm)" in mpirun|orterun|mpiexec|prterun) pids=$(pgrep -P "$parent") ;; esac
ticks=0
for p in $pids; do
  case "$(cat /proc/$p/comm)" in lmp|liggghts) ticks=$((ticks + $(awk '{print $14 + $15}' /proc/$p/stat))) ;; esac
done
echo "$1 $ticks $(getconf CLK_TCK)" >> "$2"
SH

# Shared head of both inputs: SI units, spheres from the data file in a fixed
# box split in x or y between two ranks, the 0.2 mm skin checked every step.
input_head() {  # velocity_communication_command data
  cat <<IN
units si
atom_style sphere
atom_modify map array
boundary f f f
newton off
$1
processors * * 1
read_data $2
neighbor 0.0002 bin
neigh_modify delay 0 every 1 check yes
IN
}

lammps_input() {  # data box settle steps e x_gamma_t cpu_file
  local data=$1 box=$2 settle=$3 steps=$4 e=$5 xgt=$6 cpu=$7
  local law="hertz/material 5.0e7 $e 0.25 tangential mindlin NULL $xgt 0.5 damping tsuji"
  input_head "comm_modify vel yes" "$data"
  cat <<IN
pair_style granular
pair_coeff * * $law
fix floor all wall/gran granular $law zplane 0.0 NULL
fix xwalls all wall/gran granular $law xplane 0.0 $box
fix ywalls all wall/gran granular $law yplane 0.0 $box
fix gravity all gravity 9.81 vector 0 0 -1
fix integrate all nve/sphere
timestep 5.0e-6
$(settle_and_time "$settle" "$steps" "$cpu")
IN
}

liggghts_input() {  # data box settle steps e cpu_file
  local data=$1 box=$2 settle=$3 steps=$4 e=$5 cpu=$6
  local wall="wall/gran model hertz tangential history primitive type 1"
  input_head "communicate single vel yes" "$data"
  cat <<IN
fix m1 all property/global youngsModulus peratomtype 5.0e7
fix m2 all property/global poissonsRatio peratomtype 0.25
fix m3 all property/global coefficientRestitution peratomtypepair 1 $e
fix m4 all property/global coefficientFriction peratomtypepair 1 0.5
pair_style gran model hertz tangential history
pair_coeff * *
fix floor all $wall zplane 0.0
fix xlo all $wall xplane 0.0
fix xhi all $wall xplane $box
fix ylo all $wall yplane 0.0
fix yhi all $wall yplane $box
fix gravity all gravity 9.81 vector 0 0 -1
fix integrate all nve/sphere
timestep 5.0e-6
$(settle_and_time "$settle" "$steps" "$cpu")
IN
}

# Shared tail of both inputs: end-state computes, the untimed settling run,
# the timed run between two CPU readings, the end state.
settle_and_time() {  # settle steps cpu_file
  cat <<'IN'
compute ke all ke
compute rot all erotate/sphere
compute contacts all contact/atom
compute csum all reduce sum c_contacts
compute zmax all reduce max z
variable kinetic equal c_ke+c_rot
variable coordination equal c_csum/atoms
variable top equal c_zmax+0.001
thermo_style custom step atoms c_ke c_rot c_csum c_zmax
thermo 1000000
thermo_modify lost error
IN
  cat <<IN
run $1
shell sh cpu.sh start $3
run $2
shell sh cpu.sh end $3
IN
  echo 'print "END ${kinetic} ${coordination} ${top}"'
}

# Run one peer: prints "rate cpu_rate kinetic coordination top" or "failed".
peer_result() {  # log n steps cpu_file
  local log=$1 n=$2 steps=$3 cpu=$4
  local loop end
  loop=$(grep "^Loop time" "$log" | tail -1 | awk '{print $4}')
  end=$(grep "^END " "$log" | tail -1)
  if [ -z "$loop" ] || [ -z "$end" ] || [ ! -s "$cpu" ]; then echo failed; return; fi
  awk -v n="$n" -v s="$steps" -v w="$loop" -v end="$end" '
    $1 == "start" {t0 = $2; hz = $3} $1 == "end" {t1 = $2}
    END {split(end, e, " "); printf "%.3f %.3f %.4e %.3f %.5f\n", n * s / w * 1e-6, n * s / ((t1 - t0) / hz) * 1e-6, e[2], e[3], e[4]}' "$cpu"
}

printf "%-7s %-6s %-3s %-9s %-8s %-10s %-10s %-11s %-6s %-9s\n" \
  case N thr code 2-thread Msteps/s Mper_cpu_s KE_J Z height_mm
declare -A rate
for spec in "dense 8000 $dense_settle $dense_steps" "dilute 64000 $dilute_settle $dilute_steps"; do
  read -r name n settle steps <<< "$spec"
  data=$work/$name.data
  pair=$("$bench" --n "$n" --data "$data") || { echo "dem_settling_bench --data failed" >&2; exit 1; }
  gamma=$(awk '{for (i = 1; i < NF; ++i) if ($i == "gamma") print $(i + 1)}' <<< "$pair")
  ratio=$(awk '{for (i = 1; i < NF; ++i) {if ($i == "E*") e = $(i + 1); if ($i == "G*") g = $(i + 1)}} END {print sqrt(4 * g / e)}' <<< "$pair")
  box=$(awk '/xlo xhi/ {print $2}' "$data")
  # LIGGGHTS: beta = gamma / (2 sqrt(5/6)), e = exp(-pi beta / sqrt(1 - beta^2)).
  e_liggghts=$(awk -v g="$gamma" 'BEGIN {b = g / (2 * sqrt(5 / 6)); printf "%.12g", exp(-3.14159265358979 * b / sqrt(1 - b * b))}')
  # LAMMPS: bisect Tsuji's alpha(e) (decreasing in e) for alpha = gamma sqrt(3/2).
  e_lammps=$(awk -v g="$gamma" 'function alpha(e) {return 1.2728 - 4.2783 * e + 11.087 * e^2 - 22.348 * e^3 + 27.467 * e^4 - 18.022 * e^5 + 4.8218 * e^6}
    BEGIN {t = g * sqrt(1.5); lo = 0.01; hi = 1; for (k = 0; k < 60; ++k) {m = 0.5 * (lo + hi); if (alpha(m) > t) lo = m; else hi = m}; printf "%.12g", 0.5 * (lo + hi)}')
  [ "$name" = dense ] && echo "# contact mapping: gamma $gamma; LIGGGHTS e = $e_liggghts; LAMMPS tsuji e = $e_lammps, x_gamma_t = $ratio" >&2
  for t in $threads; do
    for code in dem liggghts lammps; do
      best=failed
      for ((rep = 1; rep <= repeat; ++rep)); do
        cpu=$work/cpu_${name}_${code}_$t.txt
        log=$work/${name}_${code}_$t.log
        : > "$cpu"
        case $code in
          dem)
            how="OpenMP"
            "$bench" --n "$n" --settle "$settle" --steps "$steps" --threads "$t" > "$log" 2>&1
            result=$(awk '/^steps/ {r = $10; c = $14} /^end state/ {gsub(",", ""); for (i = 1; i < NF; ++i) {if ($i == "kinetic") k = $(i + 1); if ($i == "coordination") z = $(i + 1); if ($i == "height") h = $(i + 1)}}
                          END {if (r == "") print "failed"; else printf "%s %s %s %s %s\n", r, c, k, z, h}' "$log") ;;
          liggghts)
            how="MPI"
            liggghts_input "$data" "$box" "$settle" "$steps" "$e_liggghts" "$cpu" > in.liggghts
            if [ "$t" = 1 ]; then liggghts -in in.liggghts -log none -echo none > "$log" 2>&1
            else "${mpi[@]}" liggghts -in in.liggghts -log none -echo none > "$log" 2>&1; fi
            result=$(peer_result "$log" "$n" "$steps" "$cpu") ;;
          lammps)
            how="MPI"
            lammps_input "$data" "$box" "$settle" "$steps" "$e_lammps" "$ratio" "$cpu" > in.lammps
            if [ "$t" = 1 ]; then lmp -in in.lammps -log none -echo none > "$log" 2>&1
            else "${mpi[@]}" lmp -in in.lammps -log none -echo none > "$log" 2>&1; fi
            result=$(peer_result "$log" "$n" "$steps" "$cpu") ;;
        esac
        if [ "$result" = failed ]; then best=failed; break; fi
        if [ "$best" = failed ] || awk -v a="${result%% *}" -v b="${best%% *}" 'BEGIN {exit !(a > b)}'; then best=$result; fi
      done
      result=$best
      [ "$t" = 1 ] && how="-"
      if [ "$result" = failed ]; then
        echo "$code failed on $name, $t thread(s); log:" >&2
        tail -5 "$log" >&2
        printf "%-7s %-6s %-3s %-9s %-8s failed\n" "$name" "$n" "$t" "$code" "$how"
        continue
      fi
      read -r r c k z h <<< "$result"
      rate[$name,$t,$code]=$r
      printf "%-7s %-6s %-3s %-9s %-8s %-10s %-10s %-11s %-6s %-9s\n" "$name" "$n" "$t" "$code" "$how" "$r" "$c" "$k" "$z" \
        "$(awk -v h="$h" 'BEGIN {printf "%.2f", 1000 * h}')"
    done
    printf "%-7s %-6s %-3s dem/LIGGGHTS %s   dem/LAMMPS %s\n" "$name" "$n" "$t" \
      "$(awk -v a="${rate[$name,$t,dem]:-0}" -v b="${rate[$name,$t,liggghts]:-0}" 'BEGIN {print (b > 0 ? sprintf("%.2f", a / b) : "-")}')" \
      "$(awk -v a="${rate[$name,$t,dem]:-0}" -v b="${rate[$name,$t,lammps]:-0}" 'BEGIN {print (b > 0 ? sprintf("%.2f", a / b) : "-")}')"
  done
done
