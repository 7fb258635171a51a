# Shell steps shared by the GMH scene scripts (l3_wave_column.sh, pool_efficiency.sh, l4_cost_ratio.sh, l5_biaxial.sh,
# l4_simple_shear.sh); source it after setting root, bin and work.
# Workers run one OpenMP thread each unless OMP_NUM_THREADS is set (two
# 2-thread workers would share the two cores one worker uses).

# gmh_prepare_cell COUNT [dem_prepare_cell options...]: $work/cell.{ckpt,h5} (seed 1).
gmh_prepare_cell() {
  local count=$1
  shift
  "$bin/dem_prepare_cell" --out "$work/cell" --count "$count" --seed 1 "$@" > "$work/prepare.log"
  grep -E "^prepared" "$work/prepare.log" || true
}

# gmh_prepare_variants COUNT N [dem_prepare_cell options...]: N more cells with
# seeds 2 .. N + 1, $work/cell_s<seed>.ckpt; prints them as a YAML list
# (unit_cells.variants) on stdout.
gmh_prepare_variants() {
  local count=$1 n=$2 list="" seed
  shift 2
  for ((seed = 2; seed <= n + 1; ++seed)); do
    "$bin/dem_prepare_cell" --out "$work/cell_s$seed" --count "$count" --seed "$seed" "$@" > "$work/prepare_s$seed.log"
    grep -E "^prepared" "$work/prepare_s$seed.log" | sed "s/^/seed $seed: /" >&2 || true
    list+="${list:+, }$work/cell_s$seed.ckpt"
  done
  echo "[$list]"
}

# gmh_run SCENE [coupler run options...]: runs the scene into $work/run, log in
# $work/run.log; a run that stops early (a cell over its relaxation budget) is
# reported and its output kept for the analysis. Prints the wall time, the
# workers' share and Liu's time-step figures (Eqs. 63-66) of the run report.
gmh_run() {
  local scene=$1
  shift
  OMP_NUM_THREADS=${OMP_NUM_THREADS:-1} "$bin/coupler" run "$scene" --out "$work/run" --no-progress "$@" \
    > "$work/run.log" 2>&1 || { echo "coupler run stopped early (see $work/run.log):"; grep -m1 "error" "$work/run.log" | cut -c1-400; }
  grep -E "^  (wall time|cells_a|cells_b|figure +(fine|coarse|time_step))" "$work/run.log" || true
}

# gmh_exchange_loop RUN_DIR: the wall time of the run's exchange loop [s] (run_report.json).
gmh_exchange_loop() {
  python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['wall_s']['exchange_loop'])" "$1/run_report.json"
}
