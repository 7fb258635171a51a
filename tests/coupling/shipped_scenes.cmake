# Every scene shipped in configs/ passes `coupler check` (schedule, solvers,
# couplings and their keys): a scene that rots against the coupler's schema
# fails here, not at the start of a user's hour-long run. Solver parameters
# are validated by the solvers themselves at setup, not by `check`.
file(GLOB_RECURSE COSIM_SHIPPED_SCENES CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/configs/*.yaml)
file(MAKE_DIRECTORY ${CMAKE_BINARY_DIR}/tests/shipped-scenes)
foreach(scene ${COSIM_SHIPPED_SCENES})
  file(RELATIVE_PATH rel ${CMAKE_SOURCE_DIR}/configs ${scene})
  string(REGEX REPLACE "[/.]" "_" name "${rel}")
  add_test(NAME scene_check_${name} COMMAND $<TARGET_FILE:coupler> check ${scene}
    WORKING_DIRECTORY ${CMAKE_BINARY_DIR}/tests/shipped-scenes)
  set_tests_properties(scene_check_${name} PROPERTIES TIMEOUT 30)
endforeach()
