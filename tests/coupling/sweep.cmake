# `coupler run|check --set` and `coupler sweep`: scene overrides (unit and
# through the real coupler), sweep arguments, rows and CSV (unit), real sweeps
# of the mock demo scene, and scripts/plot_sweep.py.
cosim_test(coupling_sweep_tests
  SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/scene_overrides_test.cpp ${CMAKE_CURRENT_SOURCE_DIR}/sweep_test.cpp
  LIBS cosim_coupler cosim_test_support
  TIMEOUT 150 LABELS integration)
# The tests run the real coupler, whose runs start mock_solver.
add_dependencies(coupling_sweep_tests coupler mock_solver)
