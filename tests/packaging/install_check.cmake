# SPDX-License-Identifier: Apache-2.0
# ctest packaging.install -- run with cmake -P.
# Installs only the hapticopt_dev component (headers + CMake package) of the
# build tree BINARY_DIR into a fresh PREFIX and checks the installed files.
# Inputs: BINARY_DIR PREFIX CONFIG HEADER_SOURCE_DIR INCLUDEDIR CMAKEDIR
cmake_minimum_required(VERSION 3.25)

foreach(_var BINARY_DIR PREFIX HEADER_SOURCE_DIR INCLUDEDIR CMAKEDIR)
  if(NOT DEFINED ${_var} OR "${${_var}}" STREQUAL "")
    message(FATAL_ERROR "install_check.cmake: -D${_var}=... is required")
  endif()
endforeach()

include("${CMAKE_CURRENT_LIST_DIR}/install_component.cmake")
hapticopt_install_component("${BINARY_DIR}" "${PREFIX}" hapticopt_dev "${CONFIG}")

set(_missing "")
foreach(_f hapticoptConfig.cmake hapticoptConfigVersion.cmake hapticoptTargets.cmake)
  if(NOT EXISTS "${PREFIX}/${CMAKEDIR}/${_f}")
    list(APPEND _missing "${CMAKEDIR}/${_f}")
  endif()
endforeach()

file(GLOB_RECURSE _src_headers RELATIVE "${HEADER_SOURCE_DIR}" "${HEADER_SOURCE_DIR}/*.hpp")
foreach(_h IN LISTS _src_headers)
  if(NOT EXISTS "${PREFIX}/${INCLUDEDIR}/hapticopt/${_h}")
    list(APPEND _missing "${INCLUDEDIR}/hapticopt/${_h}")
  endif()
endforeach()

if(_missing)
  list(JOIN _missing "\n  " _missing)
  message(FATAL_ERROR "missing from the install prefix ${PREFIX}:\n  ${_missing}")
endif()

# The dev component must not drag in the applications.
file(GLOB _bins "${PREFIX}/bin/*")
if(_bins)
  message(FATAL_ERROR "component hapticopt_dev unexpectedly installed: ${_bins}")
endif()

list(LENGTH _src_headers _n)
message(STATUS "hapticopt_dev installed to ${PREFIX}: ${_n} headers + CMake package")
