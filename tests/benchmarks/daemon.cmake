# SPDX-License-Identifier: Apache-2.0
# hapticd benchmarks; included by tests/benchmarks/CMakeLists.txt when the daemon is built:
#   include("${CMAKE_CURRENT_LIST_DIR}/daemon.cmake")
# Target: hapticd_benchmarks (Google Benchmark). Run it with
#   <build>/tests/benchmarks/hapticd_benchmarks --benchmark_counters_tabular=true
if(TARGET hapticd_core)
  if(NOT TARGET benchmark::benchmark)
    find_package(benchmark REQUIRED)
  endif()
  add_executable(hapticd_benchmarks "${CMAKE_CURRENT_LIST_DIR}/daemon_tick.cpp"
    "${CMAKE_CURRENT_LIST_DIR}/engagement_check_benchmarks.cpp" "${CMAKE_CURRENT_LIST_DIR}/recorder_benchmarks.cpp"
    "${CMAKE_CURRENT_LIST_DIR}/estimator_check_benchmarks.cpp" "${CMAKE_CURRENT_LIST_DIR}/plant_set_benchmarks.cpp")
  target_link_libraries(hapticd_benchmarks PRIVATE hapticd_core benchmark::benchmark benchmark::benchmark_main)
endif()
