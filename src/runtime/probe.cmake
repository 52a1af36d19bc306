# Tests and benchmark of the bandwidth probe (the library is defined in metrics.cmake).
if(CADINTERP_BUILD_TESTING)
  cadinterp_add_test(runtime_probe_tests bandwidth_probe_test.cpp LIBS cadinterp_runtime_kernels)
endif()
if(CADINTERP_BUILD_BENCHMARKS)
  cadinterp_add_benchmark(runtime_probe_bench bandwidth_probe_bench.cpp
    LIBS cadinterp_runtime_kernels)
endif()
