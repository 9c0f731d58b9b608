# Cross build for 32-bit ARM boards (armhf, Cortex-A7/A53 in 32-bit mode) with Debian's
# g++-arm-linux-gnueabihf. OpenCV :armhf can be co-installed the same way as :arm64; when it is
# absent, configure with -DUMS_SOLVER_ONLY=ON to build and test the solver (docs/deployment.md).
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

# The cross toolchain's own sysroot: armhf libc/libstdc++ without the :armhf architecture.
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-arm -L /usr/arm-linux-gnueabihf)
