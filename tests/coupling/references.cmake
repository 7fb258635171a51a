# Analysis references that compare a run with a stored run (wave-stations, scene C2).
if("dem" IN_LIST COSIM_SOLVERS AND "fem" IN_LIST COSIM_SOLVERS)
  cosim_test(coupling_reference_run_tests
    SOURCES ${CMAKE_CURRENT_LIST_DIR}/wave_stations_test.cpp
    LIBS cosim_test_support nlohmann_json::nlohmann_json
    TIMEOUT 240 LABELS coupled slow)
  add_dependencies(coupling_reference_run_tests coupler dem_solver fem_solver)
endif()
