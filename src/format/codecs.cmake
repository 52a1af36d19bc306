# Codecs for the mesh arrays of an asset (codec.h): raw, quantization + delta + zstd,
# meshoptimizer, Draco. Included from src/format/CMakeLists.txt.
find_package(zstd REQUIRED CONFIG)
find_package(meshoptimizer REQUIRED CONFIG)
find_package(draco REQUIRED CONFIG)

add_library(cadinterp_codecs STATIC
  ${CMAKE_CURRENT_LIST_DIR}/codec.cpp
  ${CMAKE_CURRENT_LIST_DIR}/codec_quant_zstd.cpp
  ${CMAKE_CURRENT_LIST_DIR}/codec_meshopt.cpp
  ${CMAKE_CURRENT_LIST_DIR}/codec_draco.cpp)
target_include_directories(cadinterp_codecs PUBLIC ${PROJECT_SOURCE_DIR}/src)
# The libraries are an implementation detail: codec.h includes none of their headers.
target_link_libraries(cadinterp_codecs
  PRIVATE cadinterp_warnings zstd::libzstd_shared meshoptimizer::meshoptimizer draco::draco)

if(CADINTERP_BUILD_TESTS)
  cadinterp_add_test(codec_tests ${CMAKE_CURRENT_LIST_DIR}/codec_test.cpp LIBS cadinterp_codecs)
endif()
if(CADINTERP_BUILD_BENCHMARKS)
  cadinterp_add_benchmark(codec_bench ${CMAKE_CURRENT_LIST_DIR}/codec_bench.cpp
    LIBS cadinterp_codecs)
endif()
