# The asset reader/writer: FlatBuffers index generated from fileformat/cadinterp.fbs at build
# time (never committed), XXH64 checksums, the codecs of codecs.cmake.
find_package(FlatBuffers REQUIRED)
pkg_check_modules(XXHASH REQUIRED IMPORTED_TARGET GLOBAL libxxhash)
find_program(FLATC flatc REQUIRED)

set(_fbs ${PROJECT_SOURCE_DIR}/fileformat/cadinterp.fbs)
set(_gen ${CMAKE_CURRENT_BINARY_DIR}/generated)
add_custom_command(
  OUTPUT ${_gen}/cadinterp_generated.h
  COMMAND ${FLATC} --cpp --scoped-enums --gen-mutable -o ${_gen} ${_fbs}
  DEPENDS ${_fbs}
  COMMENT "flatc: cadinterp.fbs")
add_custom_target(cadinterp_fbs_header DEPENDS ${_gen}/cadinterp_generated.h)

add_library(cadinterp_format STATIC asset_reader.cpp asset_writer.cpp format_version.cpp
  synthetic_asset.cpp)
add_dependencies(cadinterp_format cadinterp_fbs_header)
target_include_directories(cadinterp_format PUBLIC ${PROJECT_SOURCE_DIR}/src ${_gen})
target_link_libraries(cadinterp_format
  PUBLIC cadinterp_core cadinterp_codecs cadinterp_headers flatbuffers::flatbuffers
  PRIVATE PkgConfig::XXHASH Threads::Threads cadinterp_warnings)

if(CADINTERP_BUILD_TESTS)
  cadinterp_add_test(format_tests asset_test.cpp LIBS cadinterp_format PkgConfig::XXHASH)
  target_compile_definitions(format_tests PRIVATE
    CADINTERP_CONFORMANCE_DIR="${PROJECT_SOURCE_DIR}/conformance/cases")
  # Schema evolution: the current schema must conform to every released one, and the check must
  # be able to fail (a schema that renumbers a field is rejected).
  add_test(NAME fileformat_conform
           COMMAND ${CMAKE_COMMAND} -E env FLATC=${FLATC}
                   bash ${PROJECT_SOURCE_DIR}/fileformat/conform_test.sh ${PROJECT_SOURCE_DIR}/fileformat)
  set_tests_properties(fileformat_conform PROPERTIES LABELS unit)
endif()
