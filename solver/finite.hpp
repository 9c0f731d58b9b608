#pragma once
// all_finite(v, n): the NaN/Inf test shared by the solver's units (set-up, linearization, solve).

#include <cmath>

namespace ums::solver {

inline bool all_finite(const double* v, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}

}  // namespace ums::solver
