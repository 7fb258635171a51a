# Arlequin volume coupling (Cheng 2022 Sec. 5.2, App. B): weight profile,
# homogenisation operator Pi (Eq. 27) in both forms, penalty forces (Eqs.
# 31-32, 41), and a short coupled run of coupler + dem_solver + fem_solver.
if(NOT ("dem" IN_LIST COSIM_SOLVERS AND "fem" IN_LIST COSIM_SOLVERS))
  return()
endif()
cosim_test(coupling_arlequin_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/arlequin_test.cpp ${CMAKE_CURRENT_LIST_DIR}/arlequin_run_test.cpp
  LIBS cosim_coupler cosim_fem cosim_test_support cosim_io
  TIMEOUT 120 LABELS coupled)
target_include_directories(coupling_arlequin_tests PRIVATE ${CMAKE_SOURCE_DIR}/tests/support)
add_dependencies(coupling_arlequin_tests coupler dem_solver fem_solver)
