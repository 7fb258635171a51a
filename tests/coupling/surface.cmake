# Surface coupling (Cheng 2022 Sec. 5.1): the contact-force maps of Eqs. 14-16
# (unit), and a short C1 run through coupler + fem_solver + dem_solver.
cosim_test(coupling_surface_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/surface_force_map_test.cpp
  LIBS cosim_coupler
  TIMEOUT 60)
if("dem" IN_LIST COSIM_SOLVERS AND "fem" IN_LIST COSIM_SOLVERS)
  cosim_test(coupling_surface_run_tests
    SOURCES ${CMAKE_CURRENT_LIST_DIR}/surface_run_test.cpp
    LIBS cosim_test_support cosim_io nlohmann_json::nlohmann_json
    TIMEOUT 420 LABELS coupled slow)
  add_dependencies(coupling_surface_run_tests coupler dem_solver fem_solver)
endif()
