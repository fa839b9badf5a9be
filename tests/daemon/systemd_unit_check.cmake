# SPDX-License-Identifier: Apache-2.0
# ctest script: the unit configured from config/hapticd.service.in is a valid unit (`systemd-analyze verify`,
# with ExecStart pointing at the built hapticd in place of the installed one, so that the executable check
# applies) and stays sandboxed (`systemd-analyze security --offline=yes`: overall exposure at most 2.0 on systemd's 0-10 scale; the shipped unit measures 1.4).
# Usage: cmake -DUNIT=<build>/config/hapticd.service -DHAPTICD=<binary> -DINSTALLED_HAPTICD=<bindir>/hapticd
#        -DOUT_DIR=<dir> -P systemd_unit_check.cmake
# Prints "SKIPPED" (the test's SKIP_REGULAR_EXPRESSION) when systemd-analyze is not installed.
find_program(SYSTEMD_ANALYZE systemd-analyze)
if(NOT SYSTEMD_ANALYZE)
  message("systemd-analyze not found: SKIPPED")
  return()
endif()
file(READ "${UNIT}" unit)
if(NOT unit MATCHES "\nExecStart=${INSTALLED_HAPTICD} ")
  message(FATAL_ERROR "systemd_unit_check: ExecStart of ${UNIT} does not start ${INSTALLED_HAPTICD}")
endif()
string(REPLACE "ExecStart=${INSTALLED_HAPTICD} " "ExecStart=${HAPTICD} " unit "${unit}")
file(MAKE_DIRECTORY "${OUT_DIR}")
set(copy "${OUT_DIR}/hapticd.service")
file(WRITE "${copy}" "${unit}")
execute_process(COMMAND "${SYSTEMD_ANALYZE}" verify "${copy}" RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT err STREQUAL "")
  message(FATAL_ERROR "systemd-analyze verify ${copy}: exit ${rc}\n${out}${err}")
endif()
# --threshold is in tenths of the exposure level.
execute_process(COMMAND "${SYSTEMD_ANALYZE}" security --offline=yes --threshold=20 "${copy}"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
string(REGEX MATCH "Overall exposure level for hapticd.service: [0-9.]+" level "${out}")
message("${level}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "systemd-analyze security: exposure above 2.0 (exit ${rc})\n${out}${err}")
endif()
