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
void tile(double* S, long ld, int i0, int j0, const TileRow* rows, int n) {
  constexpr int P = NR / 2;
  double* c0 = S + j0 * ld + i0;
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

// Column j over rows 0..j, one element at a time (an odd front's last column).
void edge(double* S, long ld, int j, const DenseSchurRows& rows) {
  double* col = S + j * ld;
  for (int i = 0; i <= j; ++i) {
    double x = col[i];
    for (int m = 0; m < rows.n; ++m) x -= rows.u2[m][2 * j] * rows.v[m][i];
    col[i] = x;
  }
}

}  // namespace

// Blocks of 4 columns (2 at the end when nf mod 4 is 2 or 3), each with the rows that reach it
// (lo before its end: the others hold exact zeros there), tiles of 4 rows down to the diagonal and
// one of 2 in a 2-column block; an odd last column element by element.
void dense_schur_update(double* S, long ld, int nf, const DenseSchurRows& rows) {
  if (rows.n > kMaxRows) {
    // In row order, kMaxRows at a time (each entry still takes the rows in order).
    for (int m0 = 0; m0 < rows.n; m0 += kMaxRows) {
      const int n = rows.n - m0 < kMaxRows ? rows.n - m0 : kMaxRows;
      dense_schur_update(S, ld, nf, DenseSchurRows{n, rows.v + m0, rows.u2 + m0, rows.lo + m0});
    }
    return;
  }
  if (rows.n <= 0) return;
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
  if (nf % 2 == 1) edge(S, ld, nf - 1, rows);
}

}  // namespace ums::solver
