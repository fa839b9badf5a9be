# SPDX-License-Identifier: Apache-2.0
# The citation check can fail: a tree (not a git work tree) with one existing and one dangling citation must
# make scripts/check-cited-paths.py exit 1 naming the dangling one, and only it.
# Usage: cmake -DPYTHON=<python3> -DSCRIPT=<check-cited-paths.py> -DWORK=<scratch dir> -P cited_paths_check.cmake
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}/src/present" "${WORK}/docs")
file(WRITE "${WORK}/src/present/here.cpp" "// the file itself\n")
file(WRITE "${WORK}/docs/page.md" "Cites src/present/here.cpp, which exists,\nand src/absent/gone.hpp, which does not.\n")
include("${CMAKE_CURRENT_LIST_DIR}/cited_paths_run.cmake")
run_cited_paths_check_expecting_failure(out)
if(NOT out MATCHES "docs/page.md:2: src/absent/gone.hpp")
  message(FATAL_ERROR "the dangling citation is not named: ${out}")
endif()
if(out MATCHES "here.cpp")
  message(FATAL_ERROR "an existing file was reported: ${out}")
endif()
message(STATUS "check-cited-paths fails on a dangling citation: ${out}")
