# libcadinterp.a: the C ABI of cadinterp.h as one static archive for integrators who link the
# runtime into their own binary. It holds the objects of the runtime's internal static libraries
# (core, codecs, format, kernels) rather than linking them as targets, so that the archive is
# self-contained and the installed CMake package exports no internal target; a consumer needs
# only the external libraries the codecs and checksums call (zstd, meshoptimizer, Draco, xxHash).
# CADINTERP_STATIC tells the public header that no DLL import applies (Windows).
#
# The codec libraries are either packages (imported targets: the consumer links them too) or,
# where a configure compiles them from source (CADINTERP_CODEC_SOURCES, src/format/codecs.cmake),
# in-tree static libraries whose objects go into the archive as well. xxHash is a shared library
# (PkgConfig::XXHASH imported) or inlined into the reader (header-only: nothing to link).
# For cmake/install.cmake, the target's properties CADINTERP_PACKAGES (the CMake packages a static
# consumer needs), CADINTERP_PC_REQUIRES and CADINTERP_PC_LIBS (its pkg-config terms).
set(_static_objects "")
set(_static_links "")
set(CADINTERP_STATIC_PACKAGES "")
set(CADINTERP_STATIC_PC_REQUIRES "")
set(CADINTERP_STATIC_PC_LIBS "")
# target, CMake package, pkg-config term (meshoptimizer has no .pc in Debian: a -l flag)
foreach(_dep "zstd::libzstd_shared|zstd|libzstd" "meshoptimizer::meshoptimizer|meshoptimizer|-lmeshoptimizer"
             "draco::draco|draco|draco")
  string(REPLACE "|" ";" _dep "${_dep}")
  list(GET _dep 0 _target)
  list(GET _dep 1 _package)
  list(GET _dep 2 _pc)
  # A package's imported targets are local to src/format, which found it: found here again.
  if(NOT TARGET ${_target})
    find_package(${_package} REQUIRED CONFIG)
  endif()
  get_target_property(_imported ${_target} IMPORTED)
  if(_imported)
    list(APPEND _static_links $<LINK_ONLY:${_target}>)
    list(APPEND CADINTERP_STATIC_PACKAGES ${_package})
    if(_pc MATCHES "^-l")
      string(APPEND CADINTERP_STATIC_PC_LIBS " ${_pc}")
    else()
      string(APPEND CADINTERP_STATIC_PC_REQUIRES " ${_pc}")
    endif()
  else()
    get_target_property(_real ${_target} ALIASED_TARGET)
    list(APPEND _static_objects $<TARGET_OBJECTS:${_real}>)
  endif()
endforeach()
get_target_property(_imported PkgConfig::XXHASH IMPORTED)
if(_imported)
  list(APPEND _static_links $<LINK_ONLY:xxhash>)
  string(APPEND CADINTERP_STATIC_PC_REQUIRES " libxxhash")
endif()

add_library(cadinterp_static STATIC
  ${CMAKE_CURRENT_LIST_DIR}/cadinterp_runtime.cpp
  ${CMAKE_CURRENT_LIST_DIR}/runtime_objects.cpp
  ${CMAKE_CURRENT_LIST_DIR}/element_cache.cpp
  ${CMAKE_CURRENT_LIST_DIR}/evaluate.cpp
  ${CMAKE_CURRENT_LIST_DIR}/blend_multi.cpp
  $<TARGET_OBJECTS:cadinterp_core>
  $<TARGET_OBJECTS:cadinterp_codecs>
  $<TARGET_OBJECTS:cadinterp_format>
  $<TARGET_OBJECTS:cadinterp_runtime_kernels>
  ${_static_objects})
# libcadinterp.a beside libcadinterp.so (or MinGW's import library libcadinterp.dll.a); MSVC
# names the DLL's import library cadinterp.lib, so the archive takes another name there.
if(MSVC)
  set_target_properties(cadinterp_static PROPERTIES OUTPUT_NAME cadinterp_static)
else()
  set_target_properties(cadinterp_static PROPERTIES OUTPUT_NAME cadinterp)
endif()
target_compile_definitions(cadinterp_static PRIVATE CADINTERP_BUILDING_LIBRARY
  PUBLIC CADINTERP_STATIC)
target_include_directories(cadinterp_static PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include>)
# The sources see the internal headers (and the generated index header) through the internal
# targets' usage requirements; $<BUILD_INTERFACE> keeps them out of the installed package.
target_link_libraries(cadinterp_static PRIVATE $<BUILD_INTERFACE:cadinterp_format>
  $<BUILD_INTERFACE:cadinterp_runtime_kernels> $<BUILD_INTERFACE:cadinterp_warnings>)
# What the archive's objects call outside it, for every consumer (LINK_ONLY: no usage
# requirements of those packages reach a consumer's compile).
target_link_libraries(cadinterp_static INTERFACE ${_static_links} $<LINK_ONLY:Threads::Threads>)
set_target_properties(cadinterp_static PROPERTIES CADINTERP_PACKAGES "${CADINTERP_STATIC_PACKAGES}"
  CADINTERP_PC_REQUIRES "${CADINTERP_STATIC_PC_REQUIRES}" CADINTERP_PC_LIBS "${CADINTERP_STATIC_PC_LIBS}")
