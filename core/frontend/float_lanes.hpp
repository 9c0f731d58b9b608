#pragma once
// Four floats in one vector register (GCC vector extension: an SSE register on x86-64, a NEON
// register on ARM), loaded and stored unaligned. The front end's window sums (KLT) and response
// kernels (Shi-Tomasi) are written with it; each lane does the scalar code's operations in its
// order, so the results do not depend on the machine.

#include <cstring>

namespace ums {

typedef float FloatLanes __attribute__((vector_size(16)));
inline constexpr int kFloatLanes = 4;

inline FloatLanes load_lanes(const float* p) {
  FloatLanes v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

inline void store_lanes(float* p, FloatLanes v) { std::memcpy(p, &v, sizeof v); }

}  // namespace ums
