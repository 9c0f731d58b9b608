#pragma once
// A dense Gaussian prior left by marginalization, kept in square-root form (research note 2.8):
//
//   r(x) = r0 + J * (x [-] x_lin),    cost = 0.5 * |r|^2,
//
// where x_lin are the first-estimate linearization points of the kept blocks (frozen when the
// prior was made), [-] is manifold_minus per block, and J (dim x dim) is a square root of the
// marginal information H = J^T J with J^T r0 = b (b: gradient of the marginalized cost at x_lin).
// J comes from a Jacobi-scaled, diagonally pivoted Cholesky that stops at the numerical rank
// (pivots below 1e-12 of the unit diagonal), so a rank-deficient marginal (gauge directions)
// stays exactly positive semi-definite and never invents information. J is upper-triangular up to
// a column permutation; rows beyond the rank are zero. No eigen-decomposition (VINS does two of
// ~170 dims per keyframe).
//
// The Jacobian of r with respect to block k's tangent is J[:, k] * B_k, with B_k = I except for a
// pose's rotation part, Jr^-1(Log(q_lin^-1 q)); add it to a Problem with Problem::add_prior.
// Big object (about 1.2 MB at kMaxReducedDim = 192): create once at start-up and reuse.

#include <Eigen/Core>

#include "solver/capacity.hpp"
#include "solver/dense_buffer.hpp"
#include "solver/manifold.hpp"
#include "solver/residual.hpp"
#include "solver/status.hpp"

namespace ums::solver {

using DenseMatrix = DenseBuffer<capacity::kMaxReducedDim, capacity::kMaxReducedDim>;
using DenseVector =
    Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, capacity::kMaxReducedDim, 1>;

struct PriorBlock {
  int source_id = -1;  // block id in the problem that was marginalized (for the caller's mapping)
  ManifoldType manifold = ManifoldType::kEuclidean;
  int ambient_size = 0;
  int tangent_size = 0;
  int offset = 0;  // first column of this block in J
  double x_lin[capacity::kMaxBlockAmbientSize] = {};  // linearization point (ambient values)
};

class MarginalPrior {
 public:
  void clear() { num_blocks_ = 0; dim_ = 0; }
  bool empty() const { return num_blocks_ == 0; }
  int num_blocks() const { return num_blocks_; }
  int dim() const { return dim_; }
  const PriorBlock& block(int i) const { return blocks_[i]; }

  // Square-root information J (dim x dim), r0 (dim), and H0 = J^T J (cached).
  ConstMatrixMap sqrt_information() const { return J_.m(); }
  const DenseVector& r0() const { return r0_; }
  ConstMatrixMap information() const { return H0_.m(); }

  // Builds the square-root prior from a marginal information H (dim x dim, symmetric; only the
  // upper triangle is read) and gradient b at the linearization points stored in blocks.
  // Returns kInvalidInput on NaN/Inf or inconsistent sizes, kFull above capacity.
  SolverStatus set_from_information(const PriorBlock* blocks, int num_blocks,
                                    const Eigen::Ref<const Eigen::MatrixXd>& H,
                                    const Eigen::Ref<const Eigen::VectorXd>& b);

  // r and (wanted) tangent Jacobians at x[i] = ambient values of prior block i. For use outside
  // Problem (tests, the Ceres benchmark); Problem linearizes a prior without forming J * B.
  bool evaluate(const double* const* x, double* r, const JacobianView* jacobians) const;

  // e = x [-] x_lin (dim), and for every pose block the rotation correction Jr^-1 (3x3 each,
  // stacked in block order into rot_jac; identity is not stored for Euclidean blocks).
  void tangent_error(const double* const* x, double* e, Eigen::Matrix3d* rot_jac) const;

 private:
  int num_blocks_ = 0;
  int dim_ = 0;
  PriorBlock blocks_[capacity::kMaxReducedBlocks];
  DenseMatrix J_;
  DenseMatrix H0_;
  DenseMatrix rows_;  // workspace of set_from_information: J's rows, columns in pivot order
  DenseVector r0_;
};

}  // namespace ums::solver
