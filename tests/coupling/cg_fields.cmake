# Coarse-grained fields of a DEM packing (Cheng 2022 Sec. 4) and the cg_fields tool.
if(TARGET cosim_dem)
  cosim_test(coupling_cg_field_tests SOURCES ${CMAKE_CURRENT_LIST_DIR}/cg_field_test.cpp
             LIBS cosim_coupler cosim_dem cosim_test_support TIMEOUT 120 LABELS integration)
  add_dependencies(coupling_cg_field_tests cg_fields)
endif()
