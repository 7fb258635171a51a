# The gmh coupling's pool bookkeeping in process: each unit-cell job answered
# once, by the worker that holds the cell.
cosim_test(coupling_gmh_answers_tests SOURCES ${CMAKE_CURRENT_LIST_DIR}/gmh_answers_test.cpp LIBS cosim_coupler TIMEOUT 60)
