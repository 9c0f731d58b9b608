#pragma once
// Whether this CPU runs the x86-64-v3 host build (cmake/UmsHostIsa.cmake): every feature of the
// level where the compiler can ask for it (GCC), else AVX2, BMI and BMI2 (clang 14 knows no level
// names). The configure-time probe and the program's start-up check both use it, so a machine the
// build was not configured on is judged the same way. False off x86-64.

namespace ums::cli {

inline bool host_runs_x86_64_v3() {
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
  __builtin_cpu_init();
#if defined(__clang__)
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2");
#else
  return __builtin_cpu_supports("x86-64-v3");
#endif
#else
  return false;
#endif
}

}  // namespace ums::cli
