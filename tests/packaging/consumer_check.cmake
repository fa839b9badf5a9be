# SPDX-License-Identifier: Apache-2.0
# ctest packaging.consumer_configure_build_run -- run with cmake -P.
# Configures the outside project SOURCE_DIR against the install PREFIX (fresh
# build dir BINARY_DIR), builds it, runs it and checks that the package was
# found in PREFIX and that the printed version is EXPECTED_VERSION.
# Inputs: SOURCE_DIR BINARY_DIR PREFIX GENERATOR EXPECTED_VERSION
#         [MAKE_PROGRAM] [CXX_COMPILER]
cmake_minimum_required(VERSION 3.25)

foreach(_var SOURCE_DIR BINARY_DIR PREFIX GENERATOR EXPECTED_VERSION)
  if(NOT DEFINED ${_var} OR "${${_var}}" STREQUAL "")
    message(FATAL_ERROR "consumer_check.cmake: -D${_var}=... is required")
  endif()
endforeach()

file(REMOVE_RECURSE "${BINARY_DIR}")

set(_args
  -S "${SOURCE_DIR}" -B "${BINARY_DIR}" -G "${GENERATOR}"
  "-DCMAKE_PREFIX_PATH=${PREFIX}"
  -DCMAKE_BUILD_TYPE=Release
  -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF
  -DCMAKE_FIND_USE_SYSTEM_PACKAGE_REGISTRY=OFF)
if(MAKE_PROGRAM)
  list(APPEND _args "-DCMAKE_MAKE_PROGRAM=${MAKE_PROGRAM}")
endif()
if(CXX_COMPILER)
  list(APPEND _args "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}")
endif()

# 1. configure
execute_process(COMMAND "${CMAKE_COMMAND}" ${_args} COMMAND_ERROR_IS_FATAL ANY)

# The package must come from PREFIX, not from some other installation.
file(STRINGS "${BINARY_DIR}/CMakeCache.txt" _dir_line REGEX "^hapticopt_DIR:")
string(REGEX REPLACE "^hapticopt_DIR:[A-Z]+=" "" _found_dir "${_dir_line}")
file(REAL_PATH "${PREFIX}" _real_prefix)
file(REAL_PATH "${_found_dir}" _real_found)
string(FIND "${_real_found}" "${_real_prefix}/" _pos)
if(NOT _pos EQUAL 0)
  message(FATAL_ERROR "hapticopt was found in '${_found_dir}', expected inside '${PREFIX}'")
endif()

# 2. build
execute_process(COMMAND "${CMAKE_COMMAND}" --build "${BINARY_DIR}" --config Release
                COMMAND_ERROR_IS_FATAL ANY)

# 3. run
find_program(_exe NAMES hapticopt_consumer
  PATHS "${BINARY_DIR}" "${BINARY_DIR}/Release" NO_DEFAULT_PATH REQUIRED)
execute_process(COMMAND "${_exe}"
  OUTPUT_VARIABLE _out ERROR_VARIABLE _err
  RESULT_VARIABLE _rc)
message(STATUS "consumer output: ${_out}${_err}")
if(NOT _rc EQUAL 0)
  message(FATAL_ERROR "hapticopt_consumer exited with '${_rc}'")
endif()
string(FIND "${_out}" "${EXPECTED_VERSION}" _pos)
if(_pos EQUAL -1)
  message(FATAL_ERROR "HAPTICOPT_VERSION_STRING printed by the consumer does not contain "
                      "the project version ${EXPECTED_VERSION} (CMakeLists.txt project(VERSION))")
endif()
