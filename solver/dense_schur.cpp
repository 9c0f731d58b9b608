#include "solver/dense_schur.hpp"

#include "solver/double_pair.hpp"

namespace ums::solver {

namespace {

constexpr int kMaxRows = 32;

// One row as a tile reads it: v, and u's packets from the tile's first column on.
struct TileRow {
  const double* v;
  const double* u;
};

// Rows i0..i0+NR-1 of columns j0..j0+NC-1 of S: -= u_m(j) v_m(i) for the listed rows in order.
template <int NR, int NC>
__attribute__((always_inline)) inline void tile(double* S, long ld, int i0, int j0, const TileRow* rows, int n) {
  constexpr int P = NR / 2;
  double* c0 = S + j0 * ld + i0;
#if defined(__AVX__)
  if constexpr (NR == 4) {  // a column's 4 rows in one quad (double_pair.hpp): the same doubles
    Quad q[NC];
    for (int j = 0; j < NC; ++j) q[j] = load_quad(c0 + j * ld);
    for (int k = 0; k < n; ++k) {
      const Quad v = load_quad(rows[k].v + i0);
      for (int j = 0; j < NC; ++j) {
        const double a = rows[k].u[2 * j];
        q[j] = q[j] - Quad{a, a, a, a} * v;
      }
    }
    for (int j = 0; j < NC; ++j) store_quad(c0 + j * ld, q[j]);
    return;
  }
#endif
  Pair s[NC][P];
  for (int j = 0; j < NC; ++j)
    for (int p = 0; p < P; ++p) s[j][p] = load_pair(c0 + j * ld + 2 * p);
  for (int k = 0; k < n; ++k) {
    Pair v[P];
    for (int p = 0; p < P; ++p) v[p] = load_pair(rows[k].v + i0 + 2 * p);
    for (int j = 0; j < NC; ++j) {
      const Pair a = load_pair(rows[k].u + 2 * j);
      for (int p = 0; p < P; ++p) s[j][p] = s[j][p] - a * v[p];
    }
  }
  for (int j = 0; j < NC; ++j)
    for (int p = 0; p < P; ++p) store_pair(c0 + j * ld + 2 * p, s[j][p]);
}

// The same for the rows m whose bits are set in use, in increasing m. Both kernels are forced
// inline: called from two places, GCC stopped inlining the list's kernel, which cost the path
// without groups 5 % more instructions.
template <int NR, int NC>
__attribute__((always_inline)) inline void tile_marked(double* S, long ld, int i0, int j0, const DenseSchurRows& rows,
                                                      std::uint32_t use) {
  constexpr int P = NR / 2;
  double* c0 = S + j0 * ld + i0;
#if defined(__AVX__)
  if constexpr (NR == 4) {
    Quad q[NC];
    for (int j = 0; j < NC; ++j) q[j] = load_quad(c0 + j * ld);
    for (; use != 0; use &= use - 1) {
      const int m = __builtin_ctz(use);
      const Quad v = load_quad(rows.v[m] + i0);
      for (int j = 0; j < NC; ++j) {
        const double a = rows.u2[m][2 * (j0 + j)];
        q[j] = q[j] - Quad{a, a, a, a} * v;
      }
    }
    for (int j = 0; j < NC; ++j) store_quad(c0 + j * ld, q[j]);
    return;
  }
#endif
  Pair s[NC][P];
  for (int j = 0; j < NC; ++j)
    for (int p = 0; p < P; ++p) s[j][p] = load_pair(c0 + j * ld + 2 * p);
  for (; use != 0; use &= use - 1) {
    const int m = __builtin_ctz(use);
    const double* vm = rows.v[m] + i0;
    const double* um = rows.u2[m] + 2 * j0;
    Pair v[P];
    for (int p = 0; p < P; ++p) v[p] = load_pair(vm + 2 * p);
    for (int j = 0; j < NC; ++j) {
      const Pair a = load_pair(um + 2 * j);
      for (int p = 0; p < P; ++p) s[j][p] = s[j][p] - a * v[p];
    }
  }
  for (int j = 0; j < NC; ++j)
    for (int p = 0; p < P; ++p) store_pair(c0 + j * ld + 2 * p, s[j][p]);
}

// Column j over rows 0..j, one element at a time (an odd front's last column).
void edge(double* S, long ld, int j, const DenseSchurRows& rows) {
  double* col = S + j * ld;
  for (int i = 0; i <= j; ++i) {
    double x = col[i];
    for (int m = 0; m < rows.n; ++m) x -= rows.u2[m][2 * j] * rows.v[m][i];
    col[i] = x;
  }
}

// Every row from lo on: each column block takes the rows that reach it (lo before its end: the
// others hold exact zeros there), all of them in each of its tiles.
void update_from_lo(double* S, long ld, int nf, const DenseSchurRows& rows) {
  TileRow list[kMaxRows];
  for (int j0 = 0; j0 + 2 <= nf;) {
    const int nc = j0 + 4 <= nf ? 4 : 2;
    int k = 0;
    for (int m = 0; m < rows.n; ++m)
      if (rows.lo[m] < j0 + nc) list[k++] = TileRow{rows.v[m], rows.u2[m] + 2 * j0};
    if (k > 0) {
      int i0 = 0;
      for (; i0 + 4 <= j0 + nc; i0 += 4)
        nc == 4 ? tile<4, 4>(S, ld, i0, j0, list, k) : tile<4, 2>(S, ld, i0, j0, list, k);
      if (i0 < j0 + nc) tile<2, 2>(S, ld, i0, j0, list, k);  // a 2-column block: rows j0, j0 + 1
    }
    j0 += nc;
  }
}

// By groups: a tile takes the rows nonzero over both its rows' and its columns' group (reach[g]:
// the rows nonzero over group g, a bit per row), in row order: its column block's list when that
// is all of them, else its rows' bits.
void update_by_groups(double* S, long ld, int nf, const DenseSchurRows& rows) {
  std::uint32_t reach[64] = {};
  for (int m = 0; m < rows.n; ++m)
    for (std::uint64_t g = rows.groups[m]; g != 0; g &= g - 1) reach[__builtin_ctzll(g)] |= 1u << m;
  TileRow list[kMaxRows];
  for (int j0 = 0; j0 + 2 <= nf;) {
    const int nc = j0 + 4 <= nf ? 4 : 2;
    const std::uint32_t cols = reach[dense_schur_group(j0)];
    int k = 0;
    for (std::uint32_t b = cols; b != 0; b &= b - 1) {
      const int m = __builtin_ctz(b);
      list[k++] = TileRow{rows.v[m], rows.u2[m] + 2 * j0};
    }
    for (int i0 = 0; k > 0 && i0 < j0 + nc; i0 += 4) {
      const std::uint32_t both = cols & reach[dense_schur_group(i0)];
      const bool four = i0 + 4 <= j0 + nc;  // else a 2-column block's rows j0, j0 + 1
      if (both == cols)
        four ? (nc == 4 ? tile<4, 4>(S, ld, i0, j0, list, k) : tile<4, 2>(S, ld, i0, j0, list, k))
             : tile<2, 2>(S, ld, i0, j0, list, k);
      else if (both != 0)
        four ? (nc == 4 ? tile_marked<4, 4>(S, ld, i0, j0, rows, both) : tile_marked<4, 2>(S, ld, i0, j0, rows, both))
             : tile_marked<2, 2>(S, ld, i0, j0, rows, both);
    }
    j0 += nc;
  }
}

}  // namespace

// Blocks of 4 columns (2 at the end when nf mod 4 is 2 or 3), tiles of 4 rows down to the diagonal
// and one of 2 in a 2-column block; an odd last column element by element.
void dense_schur_update(double* S, long ld, int nf, const DenseSchurRows& rows) {
  if (rows.n > kMaxRows) {
    // In row order, kMaxRows at a time (each entry still takes the rows in order).
    for (int m0 = 0; m0 < rows.n; m0 += kMaxRows) {
      const int n = rows.n - m0 < kMaxRows ? rows.n - m0 : kMaxRows;
      dense_schur_update(S, ld, nf,
                         DenseSchurRows{n, rows.v + m0, rows.u2 + m0, rows.lo + m0,
                                        rows.groups != nullptr ? rows.groups + m0 : nullptr});
    }
    return;
  }
  if (rows.n <= 0) return;
  if (rows.groups != nullptr)
    update_by_groups(S, ld, nf, rows);
  else
    update_from_lo(S, ld, nf, rows);
  if (nf % 2 == 1) edge(S, ld, nf - 1, rows);
}

}  // namespace ums::solver
