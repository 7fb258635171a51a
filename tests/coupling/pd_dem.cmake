# PD-DEM contact coupling (Hartmann 2022 Sec. 3): a DEM sphere pressed into a
# small PD block through coupler + pd_solver + dem_solver.
if("dem" IN_LIST COSIM_SOLVERS AND "pd" IN_LIST COSIM_SOLVERS)
  cosim_test(coupling_pd_dem_run_tests
    SOURCES ${CMAKE_CURRENT_LIST_DIR}/pd_dem_run_test.cpp
    LIBS cosim_test_support cosim_io nlohmann_json::nlohmann_json
    TIMEOUT 120 LABELS coupled)
  add_dependencies(coupling_pd_dem_run_tests coupler dem_solver pd_solver)
endif()
