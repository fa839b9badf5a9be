# SPDX-License-Identifier: Apache-2.0
# ctest packaging.compiled_mode_same_numbers -- run with cmake -P.
# Runs the header-only build HEADER_ONLY and the compiled-mode build COMPILED of the same program and
# requires both to succeed with byte-identical output.
cmake_minimum_required(VERSION 3.25)
foreach(_exe HEADER_ONLY COMPILED)
  execute_process(COMMAND "${${_exe}}" OUTPUT_VARIABLE _out_${_exe} RESULT_VARIABLE _rc)
  if(NOT _rc EQUAL 0)
    message(FATAL_ERROR "${${_exe}} exited with '${_rc}'")
  endif()
endforeach()
string(LENGTH "${_out_HEADER_ONLY}" _len)
if(_len LESS 200)
  message(FATAL_ERROR "the header-only build printed too little:\n${_out_HEADER_ONLY}")
endif()
if(NOT _out_HEADER_ONLY STREQUAL _out_COMPILED)
  message(FATAL_ERROR "compiled mode differs from header-only:\n--- header-only\n${_out_HEADER_ONLY}--- compiled\n${_out_COMPILED}")
endif()
message(STATUS "compiled mode and header-only print the same ${_len} characters:\n${_out_COMPILED}")
