#pragma once
// Packet kernels of the solver's hot loops (the Schur updates, J^T J): two doubles in one SSE2 /
// NEON register. Each keeps the scalar formula's operations and order per element, so it gives
// the same doubles as the plain loop it replaces (tests/solver/double_pair_test.cpp). GCC's vector extension
// rather than Eigen's Vector2d: its lane-wise ops round alike on every architecture (each lane is
// the scalar formula, no contraction under -ffp-contract=off) and stay SIMD when Eigen is built
// scalar for cross-architecture determinism (UMS_PORTABLE_FP).

#include <algorithm>
#include <cstring>

#include <Eigen/Core>

namespace ums::solver {

typedef double Pair __attribute__((vector_size(16)));

inline Pair load_pair(const double* p) {
  Pair v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

inline void store_pair(double* p, Pair v) { std::memcpy(p, &v, sizeof v); }

#if defined(__AVX__)
// Four doubles in one AVX register (the x86-64-v3 host build, cmake/UmsHostIsa.cmake): the
// kernels below take whole quads first, then a pair, with every element's formula unchanged, so
// they give the same doubles as on SSE2 and NEON.
typedef double Quad __attribute__((vector_size(32)));
inline Quad load_quad(const double* p) {
  Quad v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline void store_quad(double* p, Quad v) { std::memcpy(p, &v, sizeof v); }
inline Quad join_pairs(Pair lo, Pair hi) { return __builtin_shufflevector(lo, hi, 0, 1, 2, 3); }
#endif

// p[0..N) = 0. With AVX in whole quads: GCC makes a zero fill of this size a `rep stos`, whose
// start-up cost is most of the fill's time for a few hundred bytes.
template <int N>
inline void zero_doubles(double* p) {
#if defined(__AVX__)
  int i = 0;
  for (; i + 4 <= N; i += 4) store_quad(p + i, Quad{0.0, 0.0, 0.0, 0.0});
  for (; i < N; ++i) p[i] = 0.0;
#else
  std::fill(p, p + N, 0.0);
#endif
}

// y[0..n) -= c[0] x[0][0..n), then -= c[1] x[1][0..n), ... (M terms), in whole packets and one
// scalar tail. GCC vectorizes the plain loops too, but behind an aliasing check, a peel and an
// epilogue that cost more than the arithmetic at the solver's lengths (6..100).
template <int M>
inline void sub_scaled_terms(double* y, const double* c, const double* const* x, int n) {
  int i = 0;
#if defined(__AVX__)
  Quad qc[M];
  for (int k = 0; k < M; ++k) qc[k] = Quad{c[k], c[k], c[k], c[k]};
  for (; i + 4 <= n; i += 4) {
    Quad v = load_quad(y + i);
    for (int k = 0; k < M; ++k) v = v - qc[k] * load_quad(x[k] + i);
    store_quad(y + i, v);
  }
#endif
  Pair vc[M];
  for (int k = 0; k < M; ++k) vc[k] = Pair{c[k], c[k]};
  for (; i + 2 <= n; i += 2) {
    Pair v = load_pair(y + i);
    for (int k = 0; k < M; ++k) v = v - vc[k] * load_pair(x[k] + i);
    store_pair(y + i, v);
  }
  if (i < n)
    for (int k = 0; k < M; ++k) y[i] -= c[k] * x[k][i];
}

// y[0..n) -= c[0] x[0][0..n), then -= c[1] x[1][0..n), ... (m terms, 1..4): every element
// receives the terms in that order, as m passes of the plain loop y[i] -= c[k] x[k][i] would
// give, but y is read and written once.
inline void sub_scaled_sum(double* y, int m, const double* c, const double* const* x, int n) {
  switch (m) {
    case 1: return sub_scaled_terms<1>(y, c, x, n);
    case 2: return sub_scaled_terms<2>(y, c, x, n);
    case 3: return sub_scaled_terms<3>(y, c, x, n);
    default: return sub_scaled_terms<4>(y, c, x, n);
  }
}

// Hb(0..ta, 0..tb) += A^T B for row-major A (rows x ta) and B (rows x tb); Hb column-major with
// leading dimension ld. Each entry is Eigen's lazy product coefficient, the dot product summed
// from row 0 on, added to H: the same doubles, two rows of H per packet. (Eigen's own product is
// scalar here, EIGEN_DONT_VECTORIZE, and costs some 10 instructions per multiply-add at these
// dynamic sizes: the IMU factor's 15-row blocks.)
// add_jtj_rows: the same over rows [r0, r1) only, which gives the same doubles when the rows left
// out hold a zero in A or in B (a zero product added to a sum, or a sum of zeros added to H,
// changes nothing but the sign of a zero). upper (a diagonal block, A == B): only the entries
// i <= j of column j, rounded up to a whole packet (the one lower entry written is never read).
inline void add_jtj_rows(double* Hb, long ld, const double* A, int ta, const double* B, int tb, int r0, int r1,
                         bool upper) {
  if (r0 >= r1) return;
  for (int j = 0; j < tb; ++j) {
    double* col = Hb + j * ld;
    const int end = upper ? std::min((j + 2) & ~1, ta) : ta;
    int i = 0;
    for (; i + 2 <= end; i += 2) {
      Pair s = load_pair(A + r0 * ta + i) * Pair{B[r0 * tb + j], B[r0 * tb + j]};
      for (int r = r0 + 1; r < r1; ++r) s = s + load_pair(A + r * ta + i) * Pair{B[r * tb + j], B[r * tb + j]};
      store_pair(col + i, load_pair(col + i) + s);
    }
    if (i < end) {
      double s = A[r0 * ta + i] * B[r0 * tb + j];
      for (int r = r0 + 1; r < r1; ++r) s += A[r * ta + i] * B[r * tb + j];
      col[i] += s;
    }
  }
}

inline void add_jtj_any(double* Hb, long ld, const double* A, int ta, const double* B, int tb, int rows) {
  add_jtj_rows(Hb, ld, A, ta, B, tb, 0, rows, false);
}

// [*r0, *r1): the rows of J (rows x t, row-major) outside which every entry is zero (r0 == r1 when
// all are). A NaN is not zero.
inline void nonzero_rows(const double* J, int rows, int t, int* r0, int* r1) {
  auto zero_row = [&](int r) {
    for (int c = 0; c < t; ++c)
      if (!(J[r * t + c] == 0.0)) return false;
    return true;
  };
  int lo = 0, hi = rows;
  while (lo < hi && zero_row(lo)) ++lo;
  while (hi > lo && zero_row(hi - 1)) --hi;
  *r0 = lo;
  *r1 = hi;
}

// col[0..N) += a0 * b0 + a1 * b1: one column of a 2-row J^T J block in whole packets of 2.
// Written with explicit packets because GCC's own vectorizer turns the unrolled triangle into
// scalar code.
template <int N>
__attribute__((always_inline)) inline void col_update2(double* col, const Pair* a0, const Pair* a1, double b0,
                                                       double b1) {
  int i = 0;
#if defined(__AVX__)
  const Quad qb0 = {b0, b0, b0, b0}, qb1 = {b1, b1, b1, b1};
  for (; 2 * i + 4 <= N; i += 2) {
    const Quad q0 = join_pairs(a0[i], a0[i + 1]), q1 = join_pairs(a1[i], a1[i + 1]);
    store_quad(col + 2 * i, load_quad(col + 2 * i) + (q0 * qb0 + q1 * qb1));
  }
#endif
  const Pair vb0 = {b0, b0}, vb1 = {b1, b1};
  for (; i < N / 2; ++i) {
    store_pair(col + 2 * i, load_pair(col + 2 * i) + (a0[i] * vb0 + a1[i] * vb1));
  }
}

// H(0..6, 0..6) += A^T C for 2 x 6 row-major A, C; H column-major with leading dimension ld.
// Upper = true (C == A, a diagonal block): only the upper triangle, rounded up to whole packets of
// 2 rows (the few lower entries written are never read). A is held in registers across columns.
template <bool Upper>
__attribute__((always_inline)) inline void add_jtj_2x6(double* Hb, Eigen::Index ld, const double* A,
                                                       const double* C) {
  Pair a0[3], a1[3];
  for (int i = 0; i < 3; ++i) {
    a0[i] = load_pair(A + 2 * i);
    a1[i] = load_pair(A + 6 + 2 * i);
  }
  if constexpr (Upper) {
    col_update2<2>(Hb, a0, a1, A[0], A[6]);
    col_update2<2>(Hb + ld, a0, a1, A[1], A[7]);
    col_update2<4>(Hb + 2 * ld, a0, a1, A[2], A[8]);
    col_update2<4>(Hb + 3 * ld, a0, a1, A[3], A[9]);
    col_update2<6>(Hb + 4 * ld, a0, a1, A[4], A[10]);
    col_update2<6>(Hb + 5 * ld, a0, a1, A[5], A[11]);
  } else {
    for (int j = 0; j < 6; ++j) col_update2<6>(Hb + j * ld, a0, a1, C[j], C[6 + j]);
  }
}

// col[0..N) += a0 * b0 + a1 * b1 + a2 * b2 (a_k: N / 2 packets): one column of a 3-row product
// G^T X (the point-lifted landmarks' host blocks, problem_lift.cpp).
template <int N>
__attribute__((always_inline)) inline void col_update3(double* col, const Pair* a0, const Pair* a1, const Pair* a2,
                                                       double b0, double b1, double b2) {
  int i = 0;
#if defined(__AVX__)
  const Quad qb0 = {b0, b0, b0, b0}, qb1 = {b1, b1, b1, b1}, qb2 = {b2, b2, b2, b2};
  for (; 2 * i + 4 <= N; i += 2) {
    const Quad q0 = join_pairs(a0[i], a0[i + 1]), q1 = join_pairs(a1[i], a1[i + 1]), q2 = join_pairs(a2[i], a2[i + 1]);
    store_quad(col + 2 * i, load_quad(col + 2 * i) + (q0 * qb0 + q1 * qb1 + q2 * qb2));
  }
#endif
  const Pair vb0 = {b0, b0}, vb1 = {b1, b1}, vb2 = {b2, b2};
  for (; i < N / 2; ++i) {
    store_pair(col + 2 * i, load_pair(col + 2 * i) + (a0[i] * vb0 + a1[i] * vb1 + a2[i] * vb2));
  }
}

}  // namespace ums::solver
