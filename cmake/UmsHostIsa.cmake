# The x86-64 host build's instruction set. The product runs on aarch64; the host build replays,
# tests and profiles on the machine that builds it. On a machine that runs x86-64-v3 (AVX2, BMI2,
# three-operand VEX forms; board/host/host_isa.hpp asks the CPU) it compiles for it without FMA:
# the clip's pipeline, x86 callgrind, 31.2 -> 25.5 M instructions per frame (front end 16.0 ->
# 11.9) with byte-identical trajectories (docs/performance.md, session 40).
#
# Why no FMA: with -march=x86-64-v3 alone GCC 12's SLP vectorizer emits vfmaddsub (a fused
# multiply with alternating add/subtract) in 8 functions despite -ffp-contract=off (Eigen's
# eigen solvers, RelativePosePrior::evaluate, Estimator::rotation_excitation_deg, ...), one
# rounding where the scalar code has two: the replay's output quaternions moved in their 9th
# digit, and with them the host's identity with the aarch64 build (CMakeLists.txt,
# UMS_PORTABLE_FP). -mno-fma takes the instructions away.
#
# UMS_HOST_ISA: "auto" (x86-64-v3 when the configuring machine runs it, else the baseline),
# "x86-64-v3" or "baseline" (x86-64, SSE2: a binary to copy to an older machine). A v3 binary
# on a machine without it stops at start-up with a message (board/host/main.cpp).
set(UMS_HOST_ISA "auto" CACHE STRING "x86-64 host instruction set: auto, x86-64-v3 (AVX2, no FMA) or baseline")
set_property(CACHE UMS_HOST_ISA PROPERTY STRINGS auto x86-64-v3 baseline)
if(NOT UMS_HOST_ISA MATCHES "^(auto|x86-64-v3|baseline)$")
  message(FATAL_ERROR "UMS_HOST_ISA='${UMS_HOST_ISA}': expected auto, x86-64-v3 or baseline")
endif()

set(UMS_HOST_ISA_FLAGS "")
if(NOT CMAKE_CROSSCOMPILING AND CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$"
   AND CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
  set(_ums_isa "${UMS_HOST_ISA}")
  if(_ums_isa STREQUAL "auto")
    try_run(_ums_isa_run _ums_isa_compiled SOURCE_FROM_CONTENT isa_probe.cpp
            "#include \"${PROJECT_SOURCE_DIR}/board/host/host_isa.hpp\"\nint main() { return ums::cli::host_runs_x86_64_v3() ? 0 : 1; }")
    if(_ums_isa_compiled AND _ums_isa_run EQUAL 0)
      set(_ums_isa "x86-64-v3")
    else()
      set(_ums_isa "baseline")
    endif()
  endif()
  if(_ums_isa STREQUAL "x86-64-v3")
    set(UMS_HOST_ISA_FLAGS -march=x86-64-v3 -mno-fma)
    add_compile_options(${UMS_HOST_ISA_FLAGS})
  endif()
  message(STATUS "Host instruction set: ${_ums_isa} (UMS_HOST_ISA=${UMS_HOST_ISA})")
endif()
