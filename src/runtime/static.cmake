# libcadinterp.a: the C ABI of cadinterp.h as one static archive for integrators who link the
# runtime into their own binary. It holds the objects of the runtime's internal static libraries
# (core, codecs, format, kernels) rather than linking them as targets, so that the archive is
# self-contained and the installed CMake package exports no internal target; a consumer needs
# only the external libraries the codecs and checksums use (zstd, meshoptimizer, Draco, xxHash).
# CADINTERP_STATIC tells the public header that no DLL import applies (Windows).
add_library(cadinterp_static STATIC
  ${CMAKE_CURRENT_LIST_DIR}/cadinterp_runtime.cpp
  ${CMAKE_CURRENT_LIST_DIR}/runtime_objects.cpp
  ${CMAKE_CURRENT_LIST_DIR}/element_cache.cpp
  ${CMAKE_CURRENT_LIST_DIR}/evaluate.cpp
  ${CMAKE_CURRENT_LIST_DIR}/blend_multi.cpp
  $<TARGET_OBJECTS:cadinterp_core>
  $<TARGET_OBJECTS:cadinterp_codecs>
  $<TARGET_OBJECTS:cadinterp_format>
  $<TARGET_OBJECTS:cadinterp_runtime_kernels>)
set_target_properties(cadinterp_static PROPERTIES OUTPUT_NAME cadinterp)
target_compile_definitions(cadinterp_static PRIVATE CADINTERP_BUILDING_LIBRARY
  PUBLIC CADINTERP_STATIC)
target_include_directories(cadinterp_static PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include>)
# The sources see the internal headers (and the generated index header) through the internal
# targets' usage requirements; $<BUILD_INTERFACE> keeps them out of the installed package.
target_link_libraries(cadinterp_static PRIVATE $<BUILD_INTERFACE:cadinterp_format>
  $<BUILD_INTERFACE:cadinterp_runtime_kernels> $<BUILD_INTERFACE:cadinterp_warnings>)
# What the archive's objects call outside it, for every consumer (LINK_ONLY: no usage
# requirements of those packages reach a consumer's compile). The packages' imported targets are
# local to src/format, where the codecs find them, so they are found here again.
find_package(zstd REQUIRED CONFIG)
find_package(meshoptimizer REQUIRED CONFIG)
find_package(draco REQUIRED CONFIG)
target_link_libraries(cadinterp_static INTERFACE
  $<LINK_ONLY:zstd::libzstd_shared> $<LINK_ONLY:meshoptimizer::meshoptimizer>
  $<LINK_ONLY:draco::draco> $<LINK_ONLY:xxhash> $<LINK_ONLY:Threads::Threads>)
