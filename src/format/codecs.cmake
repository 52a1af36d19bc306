# Codecs for the mesh arrays of an asset (codec.h): raw, quantization + delta + zstd,
# meshoptimizer, Draco. Included from src/format/CMakeLists.txt.
# CADINTERP_CODEC_SOURCES: compile the codec libraries from scripts/fetch-codec-sources.sh's
# cache instead, for targets without packaged libraries (Windows:
# cmake/toolchains/mingw-w64.cmake), with the runtime-only configure (docs/portability.md).
set(CADINTERP_CODEC_SOURCES "" CACHE PATH "scripts/fetch-codec-sources.sh cache (empty: packages)")
if(CADINTERP_CODEC_SOURCES)
  if(CADINTERP_BUILD_BUILDER)
    message(FATAL_ERROR "CADINTERP_CODEC_SOURCES is for the runtime-only configure: add "
                        "-DCADINTERP_BUILD_BUILDER=OFF")
  endif()
  include(${PROJECT_SOURCE_DIR}/cmake/codec_sources.cmake)
  cadinterp_add_codec_sources(${CADINTERP_CODEC_SOURCES} ENCODERS)
  add_library(zstd::libzstd_shared ALIAS cadinterp_src_zstd)
  add_library(meshoptimizer::meshoptimizer ALIAS cadinterp_src_meshopt)
  add_library(draco::draco ALIAS cadinterp_src_draco)
else()
  find_package(zstd REQUIRED CONFIG)
  find_package(meshoptimizer REQUIRED CONFIG)
  find_package(draco REQUIRED CONFIG)
endif()

add_library(cadinterp_codecs STATIC
  ${CMAKE_CURRENT_LIST_DIR}/codec.cpp
  ${CMAKE_CURRENT_LIST_DIR}/codec_quant_zstd.cpp
  ${CMAKE_CURRENT_LIST_DIR}/codec_meshopt.cpp
  ${CMAKE_CURRENT_LIST_DIR}/codec_draco.cpp)
target_include_directories(cadinterp_codecs PUBLIC ${PROJECT_SOURCE_DIR}/src)
# The libraries are an implementation detail: codec.h includes none of their headers.
target_link_libraries(cadinterp_codecs
  PRIVATE cadinterp_warnings zstd::libzstd_shared meshoptimizer::meshoptimizer draco::draco)

if(CADINTERP_BUILD_TESTING)
  cadinterp_add_test(codec_tests ${CMAKE_CURRENT_LIST_DIR}/codec_test.cpp LIBS cadinterp_codecs)
endif()
if(CADINTERP_BUILD_BENCHMARKS)
  cadinterp_add_benchmark(codec_bench ${CMAKE_CURRENT_LIST_DIR}/codec_bench.cpp
    LIBS cadinterp_codecs)
endif()
