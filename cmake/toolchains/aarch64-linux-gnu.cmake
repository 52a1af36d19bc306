# Linux arm64 through Debian's g++-aarch64-linux-gnu against the multiarch :arm64 -dev packages
# (dpkg --add-architecture arm64; scripts/install-deps.sh). docs/portability.md;
# scripts/test-cross.sh arm64.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
# The multiarch packages install into /usr (lib/aarch64-linux-gnu, include): search there for
# libraries and packages, on the host for programs (flatc).
set(CMAKE_FIND_ROOT_PATH /usr/aarch64-linux-gnu /usr)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
set(ENV{PKG_CONFIG_LIBDIR} /usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig)
# ctest and add_test (and gtest_discover_tests) run the programs under qemu-user.
find_program(CADINTERP_QEMU_AARCH64 qemu-aarch64)
if(CADINTERP_QEMU_AARCH64)
  set(CMAKE_CROSSCOMPILING_EMULATOR ${CADINTERP_QEMU_AARCH64};-L;/usr/aarch64-linux-gnu)
endif()
