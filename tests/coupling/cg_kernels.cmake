# CG kernels (Cheng 2022 Eqs. 9-10): normalisation, support, shape, surface
# quadrature normalisation and the c -> 0 (Dirac) limit of the nodal map.
cosim_test(coupling_cg_kernel_tests SOURCES ${CMAKE_CURRENT_LIST_DIR}/cg_kernel_test.cpp LIBS cosim_coupler TIMEOUT 60)
