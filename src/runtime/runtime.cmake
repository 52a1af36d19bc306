# libcadinterp: the C ABI. Only CADINTERP_API symbols are exported (visibility preset hidden);
# the static internals (core, format, codecs, kernels) are linked in privately.
add_library(cadinterp SHARED
  ${CMAKE_CURRENT_LIST_DIR}/cadinterp_runtime.cpp   # the C ABI layer
  ${CMAKE_CURRENT_LIST_DIR}/runtime_objects.cpp     # the asset and workspace objects
  ${CMAKE_CURRENT_LIST_DIR}/element_cache.cpp       # decoded elements under a byte budget
  ${CMAKE_CURRENT_LIST_DIR}/evaluate.cpp            # eval, grad, vjp, properties over the kernels
  ${CMAKE_CURRENT_LIST_DIR}/blend_multi.cpp)
target_include_directories(cadinterp PUBLIC ${PROJECT_SOURCE_DIR}/include)
target_compile_definitions(cadinterp PRIVATE CADINTERP_BUILDING_LIBRARY)
target_link_libraries(cadinterp PRIVATE cadinterp_format cadinterp_runtime_kernels cadinterp_warnings)
# ABI version (soname) is kept apart from the library and format versions (CONVENTIONS.md).
set_target_properties(cadinterp PROPERTIES VERSION ${PROJECT_VERSION}
  SOVERSION ${CADINTERP_ABI_VERSION})
# Exports per platform: on ELF, hidden visibility plus the version script (symbol versions); on
# Windows, __declspec(dllexport) of CADINTERP_API alone decides (cadinterp.h).
if(CMAKE_EXECUTABLE_FORMAT STREQUAL "ELF")
  set_property(TARGET cadinterp APPEND PROPERTY LINK_DEPENDS ${CMAKE_CURRENT_LIST_DIR}/cadinterp.map)
  target_link_options(cadinterp PRIVATE -Wl,--version-script=${CMAKE_CURRENT_LIST_DIR}/cadinterp.map)
endif()

if(CADINTERP_BUILD_TESTING)
  # A C99 translation unit that includes the public headers and calls the library.
  add_executable(runtime_api_c99_test ${CMAKE_CURRENT_LIST_DIR}/api_c99_test.c)
  set_target_properties(runtime_api_c99_test PROPERTIES C_STANDARD 99 C_STANDARD_REQUIRED ON C_EXTENSIONS OFF)
  target_compile_options(runtime_api_c99_test PRIVATE -Wall -Wextra -Wpedantic -Werror)
  target_link_libraries(runtime_api_c99_test PRIVATE cadinterp)
  add_test(NAME runtime_api_c99 COMMAND runtime_api_c99_test)
  set_tests_properties(runtime_api_c99 PROPERTIES LABELS unit)

  cadinterp_add_test(runtime_tests ${CMAKE_CURRENT_LIST_DIR}/runtime_test.cpp
    LIBS cadinterp cadinterp_format cadinterp_runtime_kernels)
  cadinterp_add_test(runtime_element_queries_tests
    ${CMAKE_CURRENT_LIST_DIR}/element_queries_test.cpp
    LIBS cadinterp cadinterp_format cadinterp_runtime_kernels)
  cadinterp_add_test(runtime_open_options_tests ${CMAKE_CURRENT_LIST_DIR}/open_options_test.cpp
    LIBS cadinterp cadinterp_format)
  cadinterp_add_test(runtime_integral_tests ${CMAKE_CURRENT_LIST_DIR}/integral_test.cpp
    LIBS cadinterp cadinterp_format)
  cadinterp_add_test(runtime_outputs_tests ${CMAKE_CURRENT_LIST_DIR}/outputs_test.cpp
    LIBS cadinterp cadinterp_format)
  cadinterp_add_test(runtime_names_tests ${CMAKE_CURRENT_LIST_DIR}/runtime_names_test.cpp
    LIBS cadinterp cadinterp_format)
  cadinterp_add_test(runtime_alloc_tests ${CMAKE_CURRENT_LIST_DIR}/runtime_alloc_test.cpp
    LIBS cadinterp cadinterp_format)
  cadinterp_add_test(runtime_blend_tests ${CMAKE_CURRENT_LIST_DIR}/blend_multi_test.cpp
    ${CMAKE_CURRENT_LIST_DIR}/blend_multi.cpp LIBS cadinterp_runtime_kernels)
  cadinterp_add_test(runtime_thread_tests ${CMAKE_CURRENT_LIST_DIR}/runtime_thread_test.cpp
    LIBS cadinterp cadinterp_format Threads::Threads LABELS concurrency)
endif()

if(CADINTERP_BUILD_TESTING AND CMAKE_EXECUTABLE_FORMAT STREQUAL "ELF")
  # The shared library exports the C ABI and nothing else, under the SONAME of
  # CADINTERP_ABI_VERSION.
  add_test(NAME runtime_exports
           COMMAND bash -c "bad=$(${CMAKE_NM} -D --defined-only $<TARGET_FILE:cadinterp> | awk '{print $3}' | grep -v -e '^cadinterp_' -e '^CADINTERP_1$'); if [ -n \"$bad\" ]; then echo \"unexpected exports: $bad\"; exit 1; fi; readelf -d $<TARGET_FILE:cadinterp> | grep -q 'SONAME.*\\[libcadinterp[.]so[.]${CADINTERP_ABI_VERSION}\\]' || { echo 'SONAME is not libcadinterp.so.${CADINTERP_ABI_VERSION}'; exit 1; }; echo \"exports: $(${CMAKE_NM} -D --defined-only $<TARGET_FILE:cadinterp> | grep -c ' cadinterp_') cadinterp_* symbols\"")
  set_tests_properties(runtime_exports PROPERTIES LABELS unit)
endif()

if(CADINTERP_BUILD_BENCHMARKS)
  cadinterp_add_benchmark(runtime_bench ${CMAKE_CURRENT_LIST_DIR}/runtime_bench.cpp
    LIBS cadinterp cadinterp_format cadinterp_runtime_kernels)
  # Compiles blend_multi.cpp in as well, for the per-ISA kernels the library keeps hidden.
  cadinterp_add_benchmark(runtime_scale_bench ${CMAKE_CURRENT_LIST_DIR}/runtime_scale_bench.cpp
    ${CMAKE_CURRENT_LIST_DIR}/blend_multi.cpp
    LIBS cadinterp cadinterp_format cadinterp_runtime_kernels)
endif()

# libFuzzer targets (clang only): configure with -DCADINTERP_FUZZ=ON (scripts/fuzz.sh does).
if(CADINTERP_FUZZ)
  add_executable(fuzz_open_eval ${CMAKE_CURRENT_LIST_DIR}/fuzz_open_eval.cpp)
  # Links the format library too, for the generated index accessors (checksum fix-up).
  target_link_libraries(fuzz_open_eval PRIVATE cadinterp cadinterp_format PkgConfig::XXHASH)
  target_link_options(fuzz_open_eval PRIVATE -fsanitize=fuzzer)
  # Every query and evaluation entry point, with invariant checks on the results.
  add_executable(fuzz_api ${CMAKE_CURRENT_LIST_DIR}/fuzz_api.cpp)
  target_link_libraries(fuzz_api PRIVATE cadinterp cadinterp_format PkgConfig::XXHASH
    cadinterp_warnings)
  target_link_options(fuzz_api PRIVATE -fsanitize=fuzzer)
endif()
