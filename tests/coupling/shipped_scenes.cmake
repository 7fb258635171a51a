# Every scene shipped in configs/ passes `coupler check` (schedule, solvers,
# couplings and their keys, and each solver's own check of its params: it sets
# up from the setup message in a scratch directory) and is set up for real: `coupler run --exchanges 0`
# starts every solver it names, sends each its params and stops once all have
# answered the setup, so a scene whose solver params rot fails here, not at the
# start of a user's hour-long run. The GMH scenes read a small prepared cell
# (prepare_scene_cells.sh) under the file names they give.
file(GLOB_RECURSE COSIM_SHIPPED_SCENES CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/configs/*.yaml)
set(COSIM_SCENE_DIR ${CMAKE_BINARY_DIR}/tests/shipped-scenes)
file(MAKE_DIRECTORY ${COSIM_SCENE_DIR})
add_test(NAME scene_setup_cells
  COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/prepare_scene_cells.sh ${CMAKE_BINARY_DIR}/bin ${CMAKE_SOURCE_DIR}/configs
          ${COSIM_SCENE_DIR})
set_tests_properties(scene_setup_cells PROPERTIES TIMEOUT 120 FIXTURES_SETUP shipped_scene_cells LABELS unit)
foreach(scene ${COSIM_SHIPPED_SCENES})
  file(RELATIVE_PATH rel ${CMAKE_SOURCE_DIR}/configs ${scene})
  string(REGEX REPLACE "[/.]" "_" name "${rel}")
  add_test(NAME scene_check_${name} COMMAND $<TARGET_FILE:coupler> check ${scene}
    WORKING_DIRECTORY ${COSIM_SCENE_DIR})
  set_tests_properties(scene_check_${name} PROPERTIES TIMEOUT 120 FIXTURES_REQUIRED shipped_scene_cells
    LABELS integration)
  add_test(NAME scene_setup_${name}
    COMMAND $<TARGET_FILE:coupler> run ${scene} --exchanges 0 --no-progress --out ${COSIM_SCENE_DIR}/${name}
    WORKING_DIRECTORY ${COSIM_SCENE_DIR})
  set_tests_properties(scene_setup_${name} PROPERTIES TIMEOUT 120 FIXTURES_REQUIRED shipped_scene_cells
    LABELS integration)
endforeach()
add_test(NAME scene_setup_bad_exchange_count
  COMMAND $<TARGET_FILE:coupler> run ${CMAKE_SOURCE_DIR}/configs/demo/two_mocks.yaml --exchanges -1
  WORKING_DIRECTORY ${COSIM_SCENE_DIR})
set_tests_properties(scene_setup_bad_exchange_count PROPERTIES TIMEOUT 30 LABELS unit
  PASS_REGULAR_EXPRESSION "--exchanges: expected a whole number of exchanges \\(0 or more\\), got '-1'")
