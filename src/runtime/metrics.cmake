# Runtime numeric kernels: mass properties with their adjoints (mesh_metrics) and the blend
# kernel eval benchmarks are measured against (bandwidth_probe). Tests and benchmarks of the
# probe are in probe.cmake.
add_library(cadinterp_runtime_kernels STATIC
  mesh_metrics.cpp
  bandwidth_probe.cpp)
target_include_directories(cadinterp_runtime_kernels PUBLIC ${PROJECT_SOURCE_DIR}/src)
target_link_libraries(cadinterp_runtime_kernels PRIVATE cadinterp_warnings)

if(CADINTERP_BUILD_TESTING)
  cadinterp_add_test(runtime_metrics_tests mesh_metrics_test.cpp LIBS cadinterp_runtime_kernels)
endif()
