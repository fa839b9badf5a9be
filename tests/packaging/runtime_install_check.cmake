# SPDX-License-Identifier: Apache-2.0
# ctest packaging.runtime_install -- run with cmake -P.
# Installs the runtime component of BINARY_DIR into a fresh PREFIX and checks the GNU layout (docs/building.md,
# "Installing"): the programs, share/hapticd's config and profiles, the units (hapticd.service and the template
# hapticd@.service) with ExecStart at PREFIX/bin/hapticd,
# the sysusers.d file, the udev rules; then the installed hapticd: --help names PREFIX's config search
# (PREFIX/etc/hapticd, PREFIX/share/hapticd, found from the executable's location) and --dry-run tunes with the
# installed config and profile (exit 0).
# Inputs: BINARY_DIR PREFIX [CONFIG]
cmake_minimum_required(VERSION 3.25)
foreach(_var BINARY_DIR PREFIX)
  if(NOT DEFINED ${_var} OR "${${_var}}" STREQUAL "")
    message(FATAL_ERROR "runtime_install_check.cmake: -D${_var}=... is required")
  endif()
endforeach()
include("${CMAKE_CURRENT_LIST_DIR}/install_component.cmake")
hapticopt_install_component("${BINARY_DIR}" "${PREFIX}" runtime "${CONFIG}")
foreach(_f bin/hapticd bin/hapticctl bin/hapticopt share/hapticd/hapticd.toml share/hapticd/devices/sim.toml
           share/hapticd/devices/falcon.toml lib/systemd/system/hapticd.service lib/systemd/system/hapticd@.service
           lib/sysusers.d/hapticd.conf
           lib/udev/rules.d/70-hapticd.rules)
  if(NOT EXISTS "${PREFIX}/${_f}")
    message(FATAL_ERROR "missing from the install prefix ${PREFIX}: ${_f}")
  endif()
endforeach()
foreach(_unit hapticd.service hapticd@.service)
  file(STRINGS "${PREFIX}/lib/systemd/system/${_unit}" _exec REGEX "^ExecStart=")
  if(NOT _exec MATCHES "^ExecStart=${PREFIX}/bin/hapticd ")
    message(FATAL_ERROR "the installed ${_unit}'s ${_exec} does not start ${PREFIX}/bin/hapticd")
  endif()
endforeach()
execute_process(COMMAND "${CMAKE_COMMAND}" -E env --unset=HAPTICD_CONFIG "${PREFIX}/bin/hapticd" --help
                OUTPUT_VARIABLE _help RESULT_VARIABLE _rc)
foreach(_expected "${PREFIX}/etc/hapticd/hapticd.toml" "${PREFIX}/share/hapticd/hapticd.toml")
  string(FIND "${_help}" "${_expected}" _pos)
  if(NOT _rc EQUAL 0 OR _pos EQUAL -1)
    message(FATAL_ERROR "installed hapticd --help (exit ${_rc}) does not name ${_expected}:\n${_help}")
  endif()
endforeach()
execute_process(COMMAND "${CMAKE_COMMAND}" -E env --unset=HAPTICD_CONFIG "${PREFIX}/bin/hapticd" --dry-run
                OUTPUT_VARIABLE _out ERROR_VARIABLE _err RESULT_VARIABLE _rc)
if(NOT _rc EQUAL 0)
  message(FATAL_ERROR "installed hapticd --dry-run exited ${_rc}:\n${_out}${_err}")
endif()
message(STATUS "runtime installed to ${PREFIX}; hapticd --dry-run:\n${_out}")
