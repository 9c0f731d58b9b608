# Compile time (CI builds the tree three times, host, aarch64 and armhf, on 2 cores).
#
# GCC's garbage collector: collecting less often (the heap may grow 4x, from 1 GB, before a
# collection) makes the Eigen-heavy files compile faster, e.g. core/estimator/imu_alignment.cpp
# 29.4 s -> 22.9 s (peak 1.1 -> 1.3 GB), loop_verifier.cpp 11.6 -> 10.0 s, small files unchanged.
# It changes no generated code.
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
  add_compile_options(--param=ggc-min-expand=400 --param=ggc-min-heapsize=1048576)
endif()

# Precompiled headers: every translation unit here parses Eigen (and each test Catch2) again, about
# 1.2 s and 0.8 s of a 2.6 s average compile; most of the rest is instantiating Eigen's templates,
# which no precompiled header saves. Measured on a clean host build (ninja -j2): 902 s of compile,
# 448 s wall, before; 748 s, 371 s after. One header set per library target (CMake's
# target_precompile_headers, which also passes -Winvalid-pch: with -Werror a header that cannot be
# used fails the build instead of being parsed again). Not in the fuzz build (clang, a few small
# files). With a compiler launcher such as ccache, configure -DUMS_PCH=OFF: ccache does not cache a
# file compiled against a precompiled header unless told to be sloppy about it.
option(UMS_PCH "Precompile Eigen, the common standard headers and Catch2 (tests)" ON)

set(UMS_PCH_COMMON <Eigen/Core> <Eigen/Geometry> <algorithm> <array> <cmath> <cstdint> <string> <vector>)

# ums_precompile_headers(<target>... [TESTS] [REUSE_FROM <target>]): the common set, plus Catch2
# with TESTS; or the header already built for another target with the same flags (the test
# executables take the Catch2 main library's: one build of it instead of 30, 4 s each).
function(ums_precompile_headers)
  if(NOT UMS_PCH)
    return()
  endif()
  cmake_parse_arguments(ARG "TESTS" "REUSE_FROM" "" ${ARGN})
  set(headers ${UMS_PCH_COMMON})
  if(ARG_TESTS)
    list(APPEND headers <catch2/catch.hpp>)
  endif()
  foreach(target IN LISTS ARG_UNPARSED_ARGUMENTS)
    if(ARG_REUSE_FROM)
      target_precompile_headers(${target} REUSE_FROM ${ARG_REUSE_FROM})
    else()
      target_precompile_headers(${target} PRIVATE ${headers})
    endif()
  endforeach()
endfunction()
