#include "solver/dense_cholesky.hpp"

#include <cmath>

#include "solver/capacity.hpp"
#include "solver/double_pair.hpp"

namespace ums::solver {

namespace {

// sum_{k<m} a[k] b[k]: two packets over k = 4q .. 4q + 3, then the packets' lanes and the tail.
// Two accumulators so that consecutive adds do not wait on each other.
inline double dot_heads(const double* a, const double* b, int m) {
  Pair s0 = {0.0, 0.0}, s1 = {0.0, 0.0};
  int k = 0;
#if defined(__AVX__)
  // The two packets as one quad: lane i sums the elements i mod 4 in order, as they do.
  Quad s4 = {0.0, 0.0, 0.0, 0.0};
  for (; k + 4 <= m; k += 4) s4 = s4 + load_quad(a + k) * load_quad(b + k);
  s0 = Pair{s4[0], s4[1]};
  s1 = Pair{s4[2], s4[3]};
#else
  for (; k + 4 <= m; k += 4) {
    s0 = s0 + load_pair(a + k) * load_pair(b + k);
    s1 = s1 + load_pair(a + k + 2) * load_pair(b + k + 2);
  }
#endif
  if (k + 2 <= m) {
    s0 = s0 + load_pair(a + k) * load_pair(b + k);
    k += 2;
  }
  const Pair s = s0 + s1;
  double d = s[0] + s[1];
  if (k < m) d += a[k] * b[k];
  return d;
}

}  // namespace

bool cholesky_upper(double* A, long ld, int n) {
  if (n > capacity::kMaxReducedDim) return false;
  // 1 / U(i,i): one division per pivot instead of one per entry.
  double inv_diag[capacity::kMaxReducedDim];
  for (int j = 0; j < n; ++j) {
    double* cj = A + j * ld;
    for (int i = 0; i < j; ++i) {
      const double* ci = A + i * ld;
      cj[i] = (cj[i] - dot_heads(ci, cj, i)) * inv_diag[i];
    }
    const double d = cj[j] - dot_heads(cj, cj, j);
    if (!(d > 0.0) || !std::isfinite(d)) return false;
    cj[j] = std::sqrt(d);
    inv_diag[j] = 1.0 / cj[j];
  }
  return true;
}

void cholesky_solve_upper(const double* U, long ld, int n, double* x) {
  // U^T y = x: y_i from the head of column i.
  for (int i = 0; i < n; ++i) {
    const double* ci = U + i * ld;
    x[i] = (x[i] - dot_heads(ci, x, i)) / ci[i];
  }
  // U z = y, column by column from the last: z_j, then its column's head out of the rows above.
  for (int j = n - 1; j >= 0; --j) {
    const double* cj = U + j * ld;
    x[j] /= cj[j];
    const double zj = x[j];
    const Pair vz = {zj, zj};
    int k = 0;
    for (; k + 2 <= j; k += 2) store_pair(x + k, load_pair(x + k) - load_pair(cj + k) * vz);
    if (k < j) x[k] -= cj[k] * zj;
  }
}

}  // namespace ums::solver
