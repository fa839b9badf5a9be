# SPDX-License-Identifier: Apache-2.0
# ctest packaging.client_install_consumer -- run with cmake -P.
# Installs only the hapticd_client_dev component (include/hapticd, libhapticd_client.a, the hapticd CMake
# package) of BINARY_DIR into a fresh PREFIX, checks the files, then configures, builds and runs
# client_consumer/ against PREFIX (find_package(hapticd) -> hapticd::client, found inside PREFIX).
# Without BINARY_DIR, PREFIX is an existing installation (the Debian package's /usr,
# scripts/test-debian-packages.sh): nothing is installed or removed, the same checks and consumer run on it.
# Inputs: [BINARY_DIR] PREFIX SOURCE_DIR CONSUMER_BINARY_DIR GENERATOR [MAKE_PROGRAM] [CXX_COMPILER] [CONFIG]
cmake_minimum_required(VERSION 3.25)
foreach(_var PREFIX SOURCE_DIR CONSUMER_BINARY_DIR GENERATOR)
  if(NOT DEFINED ${_var} OR "${${_var}}" STREQUAL "")
    message(FATAL_ERROR "client_package_check.cmake: -D${_var}=... is required")
  endif()
endforeach()
file(REMOVE_RECURSE "${CONSUMER_BINARY_DIR}")
if(BINARY_DIR)
  include("${CMAKE_CURRENT_LIST_DIR}/install_component.cmake")
  hapticopt_install_component("${BINARY_DIR}" "${PREFIX}" hapticd_client_dev "${CONFIG}")
endif()
foreach(_f include/hapticd/client.hpp include/hapticd/state_layout.hpp share/cmake/hapticd/hapticdConfig.cmake
           share/cmake/hapticd/hapticdConfigVersion.cmake share/cmake/hapticd/hapticdTargets.cmake)
  if(NOT EXISTS "${PREFIX}/${_f}")
    message(FATAL_ERROR "missing from the install prefix: ${_f}")
  endif()
endforeach()
file(GLOB _libs "${PREFIX}/lib*/libhapticd_client.a" "${PREFIX}/lib*/*/libhapticd_client.a")  # lib, lib64 or a multiarch lib/<triplet>
if(NOT _libs)
  message(FATAL_ERROR "libhapticd_client.a missing from the install prefix")
endif()
set(_args -S "${SOURCE_DIR}" -B "${CONSUMER_BINARY_DIR}" -G "${GENERATOR}" "-DCMAKE_PREFIX_PATH=${PREFIX}"
          -DCMAKE_BUILD_TYPE=Release -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF -DCMAKE_FIND_USE_SYSTEM_PACKAGE_REGISTRY=OFF)
if(MAKE_PROGRAM)
  list(APPEND _args "-DCMAKE_MAKE_PROGRAM=${MAKE_PROGRAM}")
endif()
if(CXX_COMPILER)
  list(APPEND _args "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}")
endif()
execute_process(COMMAND "${CMAKE_COMMAND}" ${_args} COMMAND_ERROR_IS_FATAL ANY)
file(STRINGS "${CONSUMER_BINARY_DIR}/CMakeCache.txt" _dir_line REGEX "^hapticd_DIR:")
string(REGEX REPLACE "^hapticd_DIR:[A-Z]+=" "" _found_dir "${_dir_line}")
file(REAL_PATH "${PREFIX}" _real_prefix)
file(REAL_PATH "${_found_dir}" _real_found)
string(FIND "${_real_found}" "${_real_prefix}/" _pos)
if(NOT _pos EQUAL 0)
  message(FATAL_ERROR "hapticd was found in '${_found_dir}', expected inside '${PREFIX}'")
endif()
execute_process(COMMAND "${CMAKE_COMMAND}" --build "${CONSUMER_BINARY_DIR}" COMMAND_ERROR_IS_FATAL ANY)
execute_process(COMMAND "${CONSUMER_BINARY_DIR}/hapticd_client_consumer" RESULT_VARIABLE _rc OUTPUT_VARIABLE _out ERROR_VARIABLE _err)
message(STATUS "consumer output: ${_out}${_err}")
if(NOT _rc EQUAL 0)
  message(FATAL_ERROR "hapticd_client_consumer exited with '${_rc}'")
endif()
