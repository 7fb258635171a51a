# All dependencies come from Debian packages (scripts/setup.sh installs them).
find_package(Threads REQUIRED)
find_package(CapnProto REQUIRED)
# libzmq by header and library: its pkg-config file drags in private include
# paths (mit-krb5) whose placement changes between the first and later CMake
# runs, which made every second configure rebuild the whole tree.
find_path(ZMQ_INCLUDE_DIR zmq.h REQUIRED)
find_library(ZMQ_LIBRARY zmq REQUIRED)
if(NOT TARGET cosim::zmq)
  add_library(cosim_zmq INTERFACE)
  target_include_directories(cosim_zmq SYSTEM INTERFACE ${ZMQ_INCLUDE_DIR})
  target_link_libraries(cosim_zmq INTERFACE ${ZMQ_LIBRARY})
  add_library(cosim::zmq ALIAS cosim_zmq)
endif()
find_path(CPPZMQ_INCLUDE_DIR zmq.hpp REQUIRED)
find_package(HDF5 REQUIRED COMPONENTS C)
find_package(yaml-cpp REQUIRED)
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(nlohmann_json 3 REQUIRED)
find_package(OpenMP COMPONENTS CXX)

# HDF5's CMake config gives variables, not a target: wrap them once.
if(NOT TARGET cosim::hdf5)
  add_library(cosim_hdf5 INTERFACE)
  target_include_directories(cosim_hdf5 SYSTEM INTERFACE ${HDF5_C_INCLUDE_DIRS} ${HDF5_INCLUDE_DIRS})
  target_link_libraries(cosim_hdf5 INTERFACE ${HDF5_C_LIBRARIES} ${HDF5_LIBRARIES})
  target_compile_definitions(cosim_hdf5 INTERFACE ${HDF5_DEFINITIONS})
  add_library(cosim::hdf5 ALIAS cosim_hdf5)
endif()

# CHOLMOD (Debian's libsuitesparse-dev) for the FEM's supernodal direct
# solver. Optional: without it `direct` falls back to Eigen's SimplicialLDLT,
# several times slower on large implicit meshes, and `cholmod` is an input error.
find_path(CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
find_library(CHOLMOD_LIBRARY cholmod)
if(CHOLMOD_INCLUDE_DIR AND CHOLMOD_LIBRARY AND NOT TARGET cosim::cholmod)
  add_library(cosim_cholmod INTERFACE)
  target_include_directories(cosim_cholmod SYSTEM INTERFACE ${CHOLMOD_INCLUDE_DIR})
  target_link_libraries(cosim_cholmod INTERFACE ${CHOLMOD_LIBRARY})
  target_compile_definitions(cosim_cholmod INTERFACE COSIM_HAVE_CHOLMOD)
  add_library(cosim::cholmod ALIAS cosim_cholmod)
elseif(NOT TARGET cosim::cholmod)
  message(WARNING "CHOLMOD not found (Debian: libsuitesparse-dev): the FEM direct solver falls back to "
                  "Eigen's SimplicialLDLT, several times slower on large implicit meshes")
endif()
