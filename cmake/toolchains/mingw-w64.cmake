# Windows x86-64 through Debian's MinGW-w64 (g++-mingw-w64-x86-64), for the runtime-only configure
# (docs/portability.md; scripts/test-cross.sh windows). The codec libraries are compiled from
# source: pass -DCADINTERP_CODEC_SOURCES=<scripts/fetch-codec-sources.sh cache>.
set(CMAKE_SYSTEM_NAME Windows)
set(CMAKE_SYSTEM_PROCESSOR x86_64)
# The posix thread model: the win32 one of GCC 12 has no std::mutex or std::thread.
set(CMAKE_C_COMPILER x86_64-w64-mingw32-gcc-posix)
set(CMAKE_CXX_COMPILER x86_64-w64-mingw32-g++-posix)
set(CMAKE_RC_COMPILER x86_64-w64-mingw32-windres)
set(CMAKE_FIND_ROOT_PATH /usr/x86_64-w64-mingw32)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
# libgcc, libstdc++ and winpthread linked in: libcadinterp.dll and the programs need no MinGW
# DLLs beside them.
set(CMAKE_SHARED_LINKER_FLAGS_INIT "-static")
set(CMAKE_EXE_LINKER_FLAGS_INIT "-static")
# ctest and add_test run the programs under Wine.
find_program(CADINTERP_WINE NAMES wine64 wine)
if(CADINTERP_WINE)
  set(CMAKE_CROSSCOMPILING_EMULATOR ${CADINTERP_WINE})
endif()
