# The GMH nonlocal strain operator (Liu 2016 Eqs. 58-59, A.3-A.6) and the
# nonlocal inelastic-stress averaging built on it.
cosim_test(coupling_nonlocal_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/nonlocal_operator_test.cpp
          ${CMAKE_CURRENT_LIST_DIR}/inelastic_stress_averaging_test.cpp
  LIBS cosim_coupler
  TIMEOUT 60)
