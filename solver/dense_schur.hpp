#pragma once
// The Schur complement of 1-dof landmarks as dense rank updates of the reduced system's front rows:
// S -= sum_m u_m v_m^T on the upper triangle, with u_m = w_m v_m given. Landmarks come as dense
// rows over the front (zero outside their couplings), so runs of landmarks with different
// couplings update S together: each 4 x 4 tile of S takes the rows that reach it while it sits in
// registers (two-double packets, double_pair.hpp). Every entry still receives -(u_m(j) v_m(i)) in
// row order m = 0, 1, ..., as one row at a time would: for finite rows the same doubles (an exact
// zero subtracted changes nothing but the sign of a zero; a row left out where it is zero would
// have given 0 * inf = NaN had it been infinite elsewhere), on x86-64 and aarch64 alike in the
// portable build (UMS_PORTABLE_FP: no contraction).

#include <cstdint>

namespace ums::solver {

struct DenseSchurRows {
  int n = 0;                          // rows
  const double* const* v = nullptr;   // v[m][0..nf): the row
  const double* const* u2 = nullptr;  // u2[m][2j], u2[m][2j+1]: u_m(j) twice (a packet)
  const int* lo = nullptr;            // lo[m]: v_m and u_m are zero before it
  // Optional: bit g of groups[m] clear means v_m and u_m are zero over columns [4g, 4g + 4) (bit
  // 63: from column 252 on), e.g. a landmark's row between its last frame and the extrinsic at the
  // front's end. With it, a tile leaves out the rows that are zero over its rows or its columns
  // (they would subtract exact zeros); without it, a block of columns takes every row whose lo is
  // before its end, in all of its tiles.
  const std::uint64_t* groups = nullptr;
};

// S: column-major, leading dimension ld >= nf. Only columns [0, nf) are written, each over rows
// [0, j] rounded up to whole tiles within the front: the diagonal tiles' few lower entries are
// written too (the factorizations never read them). Any number of rows (taken 32 at a time).
void dense_schur_update(double* S, long ld, int nf, const DenseSchurRows& rows);

// The group of 4 columns column c falls in; the last group takes every column from 252 on.
inline int dense_schur_group(int c) { return c / 4 < 63 ? c / 4 : 63; }

// The groups word of a row whose nonzeros lie in columns [first, end): bits first / 4 .. (end - 1) / 4.
inline std::uint64_t dense_schur_groups(int first, int end) {
  if (end <= first) return 0;
  const int g0 = dense_schur_group(first), g1 = dense_schur_group(end - 1);
  const std::uint64_t upto = g1 >= 63 ? ~0ULL : (2ULL << g1) - 1;
  return upto & ~((1ULL << g0) - 1);
}

}  // namespace ums::solver
