#pragma once
// Dense Cholesky of the reduced system's front rows (and of a reduced system that is dense as a
// whole): A = U^T U on the upper triangle of a column-major matrix, in place. Up-looking, column
// by column: every entry is a dot product of two contiguous column heads, summed in two-double
// packets (double_pair.hpp), so the same doubles come out on x86-64 and aarch64 in the portable
// build (UMS_PORTABLE_FP: no contraction into fused multiply-adds). Eigen's blocked
// LLT runs scalar in the portable build (EIGEN_DONT_VECTORIZE) and spent about 6 instructions per
// multiply-add at the window's sizes (docs/solver.md, "Step").

namespace ums::solver {

// Factors the upper triangle of A (n x n, column-major, leading dimension ld >= n) into U, A's
// upper triangle overwritten; the strict lower triangle is neither read nor written. false: a
// pivot is not positive or not finite (A is not positive definite; A is then partly overwritten),
// or n is above capacity::kMaxReducedDim (its pivots' reciprocals are kept on the stack; the
// solver's reduced systems never are: prepare() refuses them first), A untouched.
bool cholesky_upper(double* A, long ld, int n);

// x = (U^T U)^-1 x for U from cholesky_upper (x: n doubles).
void cholesky_solve_upper(const double* U, long ld, int n, double* x);

}  // namespace ums::solver
