# The asset reader/writer: FlatBuffers index generated from fileformat/cadinterp.fbs at build
# time (never committed), XXH64 checksums, the codecs of codecs.cmake.
if(CADINTERP_CODEC_SOURCES)
  # Header-only copies in the fetch cache (codecs.cmake); XXH64 inlined, no libxxhash.
  add_library(cadinterp_src_headers INTERFACE)
  target_include_directories(cadinterp_src_headers SYSTEM INTERFACE ${CADINTERP_CODEC_SOURCES}/include)
  target_compile_definitions(cadinterp_src_headers INTERFACE XXH_INLINE_ALL)
  add_library(flatbuffers::flatbuffers ALIAS cadinterp_src_headers)
  add_library(PkgConfig::XXHASH ALIAS cadinterp_src_headers)
else()
  find_package(FlatBuffers REQUIRED)
  pkg_check_modules(XXHASH REQUIRED IMPORTED_TARGET GLOBAL libxxhash)
endif()
# The host's flatc (the generated header does not depend on the target).
find_program(FLATC flatc REQUIRED NO_CMAKE_FIND_ROOT_PATH)

set(_fbs ${PROJECT_SOURCE_DIR}/fileformat/cadinterp.fbs)
set(_gen ${CMAKE_CURRENT_BINARY_DIR}/generated)
add_custom_command(
  OUTPUT ${_gen}/cadinterp_generated.h
  COMMAND ${FLATC} --cpp --scoped-enums --gen-mutable -o ${_gen} ${_fbs}
  DEPENDS ${_fbs}
  COMMENT "flatc: cadinterp.fbs")
add_custom_target(cadinterp_fbs_header DEPENDS ${_gen}/cadinterp_generated.h)

# The reader's memory mapping, per operating system (mapped_file.h).
if(WIN32)
  set(_mapped_file mapped_file_win32.cpp)
else()
  set(_mapped_file mapped_file_posix.cpp)
endif()
add_library(cadinterp_format STATIC asset_reader.cpp ${_mapped_file} asset_writer.cpp
  format_version.cpp error_model.cpp
  synthetic_asset.cpp)
add_dependencies(cadinterp_format cadinterp_fbs_header)
target_include_directories(cadinterp_format PUBLIC ${PROJECT_SOURCE_DIR}/src ${_gen})
target_link_libraries(cadinterp_format
  PUBLIC cadinterp_core cadinterp_codecs cadinterp_headers flatbuffers::flatbuffers
  PRIVATE PkgConfig::XXHASH Threads::Threads cadinterp_warnings)

if(CADINTERP_BUILD_TESTING)
  cadinterp_add_test(format_tests asset_test.cpp error_model_test.cpp LIBS cadinterp_format PkgConfig::XXHASH)
  target_compile_definitions(format_tests PRIVATE
    CADINTERP_CONFORMANCE_DIR="${PROJECT_SOURCE_DIR}/conformance/cases")
  # Schema evolution: the current schema must conform to every released one, and the check must
  # be able to fail (a schema that renumbers a field is rejected).
  add_test(NAME fileformat_conform
           COMMAND ${CMAKE_COMMAND} -E env FLATC=${FLATC}
                   bash ${PROJECT_SOURCE_DIR}/fileformat/conform_test.sh ${PROJECT_SOURCE_DIR}/fileformat)
  set_tests_properties(fileformat_conform PROPERTIES LABELS unit)
endif()
