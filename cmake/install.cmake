# `cmake --install`: the public headers, libcadinterp (shared and static), libcadinterp_builder,
# the `cadinterp` tool and its host worker, the CMake package (cadinterpConfig.cmake, its version
# file and the exported targets cadinterp::runtime, cadinterp::runtime_static, cadinterp::builder and,
# with Ipopt, cadinterp::optimize) and
# cadinterp.pc. Included last from the top-level CMakeLists.txt, when every target exists; a
# runtime-only build (no builder) installs the rest. scripts/test-install.sh consumes a staged
# install of it.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(CADINTERP_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/cadinterp
    CACHE STRING "Where cadinterpConfig.cmake is installed, relative to the prefix")

install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/cadinterp
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
        COMPONENT runtime_dev FILES_MATCHING PATTERN "*.h" PATTERN "*.hpp")

# The libraries' build trees point their include paths into the source tree; the installed
# package must point at the installed headers instead (INCLUDES DESTINATION below), so only the
# build-tree path is kept, as a $<BUILD_INTERFACE>.
set(_cadinterp_libs cadinterp cadinterp_static)
if(TARGET cadinterp_builder)
  list(APPEND _cadinterp_libs cadinterp_builder)
endif()
if(TARGET cadinterp_optimize)
  list(APPEND _cadinterp_libs cadinterp_optimize)
endif()
foreach(_lib IN LISTS _cadinterp_libs)
  set_property(TARGET ${_lib} PROPERTY INTERFACE_INCLUDE_DIRECTORIES
               $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include>)
endforeach()
set_target_properties(cadinterp PROPERTIES EXPORT_NAME runtime)
set_target_properties(cadinterp_static PROPERTIES EXPORT_NAME runtime_static)
if(TARGET cadinterp_builder)
  set_target_properties(cadinterp_builder PROPERTIES EXPORT_NAME builder)
endif()
if(TARGET cadinterp_optimize)
  set_target_properties(cadinterp_optimize PROPERTIES EXPORT_NAME optimize)
endif()

install(TARGETS ${_cadinterp_libs} EXPORT cadinterpTargets
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT runtime
                NAMELINK_COMPONENT runtime_dev
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT runtime_dev
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})

# The tool finds the installed libraries next to it, wherever the prefix is moved to.
if(TARGET cadinterp_cli)
  file(RELATIVE_PATH _bin_to_lib ${CMAKE_INSTALL_FULL_BINDIR} ${CMAKE_INSTALL_FULL_LIBDIR})
  set_target_properties(cadinterp_cli PROPERTIES INSTALL_RPATH "$ORIGIN/${_bin_to_lib}")
  install(TARGETS cadinterp_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT tools)
endif()
# `cadinterp build --isolate` runs hosts in this worker, which it finds beside itself.
if(TARGET cadinterp-host-worker)
  set_target_properties(cadinterp-host-worker PROPERTIES INSTALL_RPATH "$ORIGIN/${_bin_to_lib}")
  install(TARGETS cadinterp-host-worker RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT tools)
endif()

install(EXPORT cadinterpTargets NAMESPACE cadinterp:: FILE cadinterpTargets.cmake
        DESTINATION ${CADINTERP_INSTALL_CMAKEDIR} COMPONENT runtime_dev)
get_target_property(CADINTERP_STATIC_PACKAGES cadinterp_static CADINTERP_PACKAGES)
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/cadinterpConfig.cmake.in
  ${PROJECT_BINARY_DIR}/cadinterpConfig.cmake INSTALL_DESTINATION ${CADINTERP_INSTALL_CMAKEDIR})
# The C ABI keeps its promises within a major version (CONVENTIONS.md).
write_basic_package_version_file(${PROJECT_BINARY_DIR}/cadinterpConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMajorVersion)
install(FILES ${PROJECT_BINARY_DIR}/cadinterpConfig.cmake
              ${PROJECT_BINARY_DIR}/cadinterpConfigVersion.cmake
        DESTINATION ${CADINTERP_INSTALL_CMAKEDIR} COMPONENT runtime_dev)

# pkg-config: the .pc names the installed directories (absolute, as Debian's own do), so a staged
# install is read with PKG_CONFIG_SYSROOT_DIR. For a static link (pkg-config --static) it lists
# what libcadinterp.a's objects call (src/runtime/static.cmake): packages with a .pc in
# Requires.private, others and the C++ runtime in Libs.private. A C program's link does not add
# the C++ runtime by itself: the C++ compiler's implicit libraries that the C compiler's lack.
get_target_property(CADINTERP_STATIC_PC_REQUIRES cadinterp_static CADINTERP_PC_REQUIRES)
get_target_property(CADINTERP_STATIC_PC_LIBS cadinterp_static CADINTERP_PC_LIBS)
set(CADINTERP_STATIC_PC_CXX "")
foreach(_l IN LISTS CMAKE_CXX_IMPLICIT_LINK_LIBRARIES)
  if(NOT _l IN_LIST CMAKE_C_IMPLICIT_LINK_LIBRARIES)
    string(APPEND CADINTERP_STATIC_PC_CXX " -l${_l}")
  endif()
endforeach()
configure_file(${CMAKE_CURRENT_LIST_DIR}/cadinterp.pc.in ${PROJECT_BINARY_DIR}/cadinterp.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/cadinterp.pc
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig COMPONENT runtime_dev)
