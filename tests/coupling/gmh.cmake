# GMH (Liu 2016): FEM with the external material and a pool of two dem_solver
# unit-cell workers, coupled by `kind: gmh` (coupler + fem_solver + dem_solver).
if("dem" IN_LIST COSIM_SOLVERS AND "fem" IN_LIST COSIM_SOLVERS)
  cosim_test(coupling_gmh_run_tests
    SOURCES ${CMAKE_CURRENT_LIST_DIR}/gmh_run_test.cpp
    LIBS cosim_test_support cosim_io nlohmann_json::nlohmann_json
    TIMEOUT 300)
  add_dependencies(coupling_gmh_run_tests coupler dem_solver fem_solver dem_prepare_cell)
endif()
