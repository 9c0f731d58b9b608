# Cross build for 32-bit ARM boards (armhf, Cortex-A7/A53 in 32-bit mode) with Debian's
# g++-arm-linux-gnueabihf. OpenCV :armhf is co-installed the same way as :arm64 (scripts/deps.sh);
# when it cannot be, configure with -DUMS_SOLVER_ONLY=ON to build and test the solver
# (docs/deployment.md).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(CMAKE_C_COMPILER arm-linux-gnueabihf-gcc)
set(CMAKE_CXX_COMPILER arm-linux-gnueabihf-g++)
set(CMAKE_LIBRARY_ARCHITECTURE arm-linux-gnueabihf)

set(CMAKE_FIND_ROOT_PATH /)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_IGNORE_PATH /usr/lib/x86_64-linux-gnu /lib/x86_64-linux-gnu)
set(CMAKE_LIBRARY_PATH /usr/lib/arm-linux-gnueabihf /lib/arm-linux-gnueabihf)

# With the :armhf architecture installed (OpenCV for the whole build) the binaries link against
# /usr/lib/arm-linux-gnueabihf and must run on its libc (qemu-arm -L /): mixing in the cross
# toolchain's own sysroot crashes every test that starts a thread. Without it (solver only), the
# cross toolchain's sysroot is the only armhf libc there is.
if(EXISTS /usr/lib/arm-linux-gnueabihf/libc.so.6)
  set(CMAKE_CROSSCOMPILING_EMULATOR qemu-arm -L /)
else()
  set(CMAKE_CROSSCOMPILING_EMULATOR qemu-arm -L /usr/arm-linux-gnueabihf)
endif()
