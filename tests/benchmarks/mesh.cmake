# SPDX-License-Identifier: Apache-2.0
# The mesh benchmarks (docs/mesh-rendering.md); included by tests/benchmarks/CMakeLists.txt when the daemon is built.
# Target: hapticd_mesh_benchmarks (Google Benchmark). Run it with
#   <build>/tests/benchmarks/hapticd_mesh_benchmarks --benchmark_counters_tabular=true
# With Debian's libembree-dev installed (scripts/install-deps.sh lists it; optional here), the same segment
# queries also run through Embree 3 (rtcIntersect1) for the comparison of docs/mesh-rendering.md.
if(TARGET hapticd_mesh)
  if(NOT TARGET benchmark::benchmark)
    find_package(benchmark REQUIRED)
  endif()
  add_executable(hapticd_mesh_benchmarks "${CMAKE_CURRENT_LIST_DIR}/mesh_benchmarks.cpp")
  target_link_libraries(hapticd_mesh_benchmarks PRIVATE hapticd_mesh hapticd_scene benchmark::benchmark
                        benchmark::benchmark_main)
  find_package(embree 3 CONFIG QUIET)
  if(embree_FOUND)
    target_link_libraries(hapticd_mesh_benchmarks PRIVATE embree)
    target_compile_definitions(hapticd_mesh_benchmarks PRIVATE HAPTICD_BENCHMARK_EMBREE=1)
  endif()
endif()
