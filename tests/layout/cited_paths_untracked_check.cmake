# SPDX-License-Identifier: Apache-2.0
# In a git work tree the citation check resolves against the tracked files: a cited file that exists in the
# checkout but is not tracked is dangling (a clean clone lacks it), and a path through a folder named build is
# a build tree, not a citation. Needs git.
# Usage: cmake -DPYTHON=<python3> -DGIT=<git> -DSCRIPT=<check-cited-paths.py> -DWORK=<scratch dir>
#        -P cited_paths_untracked_check.cmake
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}/src/present" "${WORK}/docs" "${WORK}/python/build")
file(WRITE "${WORK}/src/present/tracked.cpp" "// tracked\n")
file(WRITE "${WORK}/src/present/untracked.cpp" "// exists, not tracked\n")
file(WRITE "${WORK}/python/build/product.o" "")
file(WRITE "${WORK}/docs/page.md"
  "Cites src/present/tracked.cpp,\nsrc/present/untracked.cpp\nand the build tree python/build/product.o.\n")
foreach(step "init;-q" "add;src/present/tracked.cpp;docs/page.md")
  execute_process(COMMAND "${GIT}" -C "${WORK}" ${step} RESULT_VARIABLE code ERROR_VARIABLE err)
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "git ${step} failed: ${err}")
  endif()
endforeach()
include("${CMAKE_CURRENT_LIST_DIR}/cited_paths_run.cmake")
run_cited_paths_check_expecting_failure(out)
if(NOT out STREQUAL "docs/page.md:2: src/present/untracked.cpp\n")
  message(FATAL_ERROR "expected only the untracked file to be reported, got: ${out}")
endif()
message(STATUS "check-cited-paths reports the untracked citation only: ${out}")
