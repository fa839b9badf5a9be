# SPDX-License-Identifier: Apache-2.0
# ctest script: the unit configured from config/hapticd.service.in is a valid unit (`systemd-analyze verify`,
# with ExecStart pointing at the built hapticd in place of the installed one, so that the executable check
# applies) and stays sandboxed (`systemd-analyze security --offline=yes`: overall exposure at most 2.0 on systemd's 0-10 scale; the shipped unit measures 1.4).
# With -DTEMPLATE=<build>/config/hapticd@.service, the same for the template unit's instance hapticd@left.service,
# and the template's settings are the unit's but for Description and ExecStart (which must pass --instance %i).
# Usage: cmake -DUNIT=<build>/config/hapticd.service [-DTEMPLATE=<build>/config/hapticd@.service] -DHAPTICD=<binary>
#        -DINSTALLED_HAPTICD=<bindir>/hapticd -DOUT_DIR=<dir> -P systemd_unit_check.cmake
# Prints "SKIPPED" (the test's SKIP_REGULAR_EXPRESSION) when systemd-analyze is not installed.
find_program(SYSTEMD_ANALYZE systemd-analyze)
if(NOT SYSTEMD_ANALYZE)
  message("systemd-analyze not found: SKIPPED")
  return()
endif()
# The settings of a unit's text: its lines without comments and blank lines, Description and ExecStart removed.
function(unit_settings text out)
  string(REPLACE ";" "\\;" text "${text}")
  string(REPLACE "\n" ";" lines "${text}")
  set(kept "")
  foreach(line IN LISTS lines)
    if(line STREQUAL "" OR line MATCHES "^#" OR line MATCHES "^(Description|ExecStart)=")
      continue()
    endif()
    string(APPEND kept "${line}\n")
  endforeach()
  set(${out} "${kept}" PARENT_SCOPE)
endfunction()

# Checks the unit file `source` (verified and rated as the unit `verify_as`, a file name in OUT_DIR).
function(check_unit source copy_name verify_as)
  file(READ "${source}" unit)
  if(NOT unit MATCHES "\nExecStart=${INSTALLED_HAPTICD} ")
    message(FATAL_ERROR "systemd_unit_check: ExecStart of ${source} does not start ${INSTALLED_HAPTICD}")
  endif()
  string(REPLACE "ExecStart=${INSTALLED_HAPTICD} " "ExecStart=${HAPTICD} " unit "${unit}")
  file(MAKE_DIRECTORY "${OUT_DIR}")
  file(WRITE "${OUT_DIR}/${copy_name}" "${unit}")
  set(target "${OUT_DIR}/${verify_as}")
  execute_process(COMMAND "${SYSTEMD_ANALYZE}" verify "${target}" RESULT_VARIABLE rc OUTPUT_VARIABLE out
                  ERROR_VARIABLE err)
  if(NOT rc EQUAL 0 OR NOT err STREQUAL "")
    message(FATAL_ERROR "systemd-analyze verify ${target}: exit ${rc}\n${out}${err}")
  endif()
  # --threshold is in tenths of the exposure level.
  execute_process(COMMAND "${SYSTEMD_ANALYZE}" security --offline=yes --threshold=20 "${target}"
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  string(REGEX MATCH "Overall exposure level for ${verify_as}: [0-9.]+" level "${out}")
  message("${level}")
  if(NOT rc EQUAL 0 OR level STREQUAL "")
    message(FATAL_ERROR "systemd-analyze security ${target}: exposure above 2.0 (exit ${rc})\n${out}${err}")
  endif()
endfunction()

check_unit("${UNIT}" hapticd.service hapticd.service)
if(DEFINED TEMPLATE)
  # systemd instantiates hapticd@left.service from hapticd@.service in the same directory.
  check_unit("${TEMPLATE}" "hapticd@.service" "hapticd@left.service")
  file(READ "${UNIT}" unit)
  file(READ "${TEMPLATE}" template)
  if(NOT template MATCHES "\nExecStart=${INSTALLED_HAPTICD} --instance %i ")
    message(FATAL_ERROR "systemd_unit_check: ExecStart of ${TEMPLATE} does not pass --instance %i first")
  endif()
  unit_settings("${unit}" unit_kept)
  unit_settings("${template}" template_kept)
  if(NOT unit_kept STREQUAL template_kept)
    file(WRITE "${OUT_DIR}/unit.settings" "${unit_kept}")
    file(WRITE "${OUT_DIR}/template.settings" "${template_kept}")
    message(FATAL_ERROR "systemd_unit_check: the settings of ${TEMPLATE} differ from ${UNIT}'s beyond Description and "
                        "ExecStart: compare ${OUT_DIR}/unit.settings and ${OUT_DIR}/template.settings")
  endif()
  message("hapticd@.service: the settings of hapticd.service but Description and ExecStart")
endif()
