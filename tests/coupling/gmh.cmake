# GMH (Liu 2016): FEM with the external material and a pool of two dem_solver
# unit-cell workers, coupled by `kind: gmh` (coupler + fem_solver + dem_solver).
if("dem" IN_LIST COSIM_SOLVERS AND "fem" IN_LIST COSIM_SOLVERS)
  cosim_test(coupling_gmh_run_tests
    SOURCES ${CMAKE_CURRENT_LIST_DIR}/gmh_run_test.cpp
    LIBS cosim_test_support cosim_io nlohmann_json::nlohmann_json
    TIMEOUT 660 LABELS coupled slow)
  add_dependencies(coupling_gmh_run_tests coupler dem_solver fem_solver dem_prepare_cell)
endif()

# Scene L2 in small: a 100-sphere cell, 30 coarse steps of compression and of
# simple shear; GMH (one element, one worker) against the direct DEM test of
# the same cell along the same path must agree within 2 % RMS of the peak.
if("dem" IN_LIST COSIM_SOLVERS AND "fem" IN_LIST COSIM_SOLVERS AND COSIM_BUILD_BENCH)
  # The corotational direct test must agree within 0.2 % (the loop, to round-off).
  add_test(NAME coupling_gmh_l2_compare COMMAND ${CMAKE_SOURCE_DIR}/bench/gmh/l2_compare.sh 100 30 0.02)
  set_tests_properties(coupling_gmh_l2_compare PROPERTIES TIMEOUT 300 LABELS coupled
    ENVIRONMENT "COSIM_BIN=${CMAKE_BINARY_DIR}/bin;L2_WORK=${CMAKE_BINARY_DIR}/tests/gmh-l2")
  # The cells in the spatial frame (fem_solver's material frame: spatial): the
  # spatial direct test is then GMH's own frame and must agree within 0.2 %.
  add_test(NAME coupling_gmh_l2_compare_spatial COMMAND ${CMAKE_SOURCE_DIR}/bench/gmh/l2_compare.sh 100 30 0.02)
  set_tests_properties(coupling_gmh_l2_compare_spatial PROPERTIES TIMEOUT 300 LABELS coupled
    ENVIRONMENT "COSIM_BIN=${CMAKE_BINARY_DIR}/bin;L2_WORK=${CMAKE_BINARY_DIR}/tests/gmh-l2-spatial;L2_FRAME=spatial")
endif()
