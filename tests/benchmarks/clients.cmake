# SPDX-License-Identifier: Apache-2.0
# Client-interface benchmarks (docs/clients.md), included by tests/benchmarks/CMakeLists.txt with the daemon:
#   <build>/tests/benchmarks/hapticd_client_benchmarks --benchmark_counters_tabular=true
if(TARGET hapticd_core AND TARGET hapticd_client)
  if(NOT TARGET benchmark::benchmark)
    find_package(benchmark REQUIRED)
  endif()
  add_executable(hapticd_client_benchmarks "${CMAKE_CURRENT_LIST_DIR}/clients_benchmarks.cpp")
  target_link_libraries(hapticd_client_benchmarks PRIVATE hapticd_core hapticd_client benchmark::benchmark)
  hapticopt_test_paths(hapticd_client_benchmarks HAPTICD_BINARY "$<TARGET_FILE:hapticd>")
  target_include_directories(hapticd_client_benchmarks PRIVATE "${PROJECT_SOURCE_DIR}/tests")  # tests/common/
  add_dependencies(hapticd_client_benchmarks hapticd)
endif()
