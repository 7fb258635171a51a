# Sourced by the bench scripts of bench/coupled (H3-H5).

# solver_bin DIR: prints the directory holding coupler, pd_solver and
# dem_solver, given that directory or a build directory with them in bin/;
# fails (2) naming DIR when neither has them.
solver_bin() {
  local bin=$1
  [ -x "$bin/bin/coupler" ] && bin=$bin/bin
  [ -x "$bin/coupler" ] || { echo "no coupler in $bin (nor $bin/bin)" >&2; return 2; }
  echo "$bin"
}

# run_pd_scene NAME CONFIG SCALE [coupler run options ...]: runs CONFIG into
# $work/NAME (one OpenMP thread unless OMP_NUM_THREADS is set) and prints
# pd_scene_stats.py NAME for it, the paper's times divided by SCALE. Needs
# $root, $bin and $work.
run_pd_scene() {
  local name=$1 config=$2 scale=$3
  shift 3
  local out=$work/$name
  OMP_NUM_THREADS=${OMP_NUM_THREADS:-1} "$bin/coupler" run "$config" --out "$out" --no-progress "$@" \
    > "$work/$name.log" 2>&1 || echo "coupler run exited with $? (see $work/$name.log)"
  /usr/bin/python3 "$root/bench/coupled/pd_scene_stats.py" "$name" "$out" --time-scale "$scale" \
    --label "$name (x$scale speed)"
  echo "run kept in $out"
}
