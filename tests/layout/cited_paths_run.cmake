# SPDX-License-Identifier: Apache-2.0
# Included by the citation check's own tests (cited_paths_check.cmake, cited_paths_untracked_check.cmake):
# run_cited_paths_check_expecting_failure(OUT) runs ${SCRIPT} with ${PYTHON} on the tree ${WORK}, fails the test
# unless the script exits 1, and sets OUT to what it printed on stdout (the dangling citations, one per line).
function(run_cited_paths_check_expecting_failure out_var)
  execute_process(COMMAND "${PYTHON}" "${SCRIPT}" "${WORK}" RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT code EQUAL 1)
    message(FATAL_ERROR "expected exit 1, got ${code}: ${out}${err}")
  endif()
  set(${out_var} "${out}" PARENT_SCOPE)
endfunction()
