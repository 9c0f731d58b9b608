#include "solver/marginal_prior.hpp"

#include <algorithm>
#include <cmath>

#include "solver/capacity.hpp"
#include "solver/double_pair.hpp"

namespace ums::solver {

namespace {

// Block layout (consecutive offsets, tangent sizes of their manifolds), capacity, sizes, and
// finite values in H's upper triangle and b. *dim: the prior's dimension.
SolverStatus check_information(const PriorBlock* blocks, int num_blocks,
                               const Eigen::Ref<const Eigen::MatrixXd>& H,
                               const Eigen::Ref<const Eigen::VectorXd>& b, int* dim) {
  if (num_blocks < 0) return SolverStatus::kInvalidInput;
  if (num_blocks > capacity::kMaxReducedBlocks) return SolverStatus::kFull;
  *dim = 0;
  for (int i = 0; i < num_blocks; ++i) {
    if (blocks[i].offset != *dim ||
        blocks[i].tangent_size != tangent_size(blocks[i].manifold, blocks[i].ambient_size))
      return SolverStatus::kInvalidInput;
    *dim += blocks[i].tangent_size;
  }
  if (*dim > capacity::kMaxReducedDim) return SolverStatus::kFull;
  if (H.rows() != *dim || H.cols() != *dim || b.size() != *dim) return SolverStatus::kInvalidInput;
  for (int c = 0; c < *dim; ++c) {
    if (!std::isfinite(b[c])) return SolverStatus::kInvalidInput;
    for (int r = 0; r <= c; ++r)
      if (!std::isfinite(H(r, c))) return SolverStatus::kInvalidInput;
  }
  return SolverStatus::kOk;
}

// Rows and columns a < b of a symmetric matrix swapped where only its upper triangle is kept
// (the factor's rows above a, in the same triangle, have their columns swapped too).
void swap_symmetric_upper(MatrixMap W, int dim, int a, int b) {
  std::swap(W(a, a), W(b, b));
  for (int i = 0; i < a; ++i) std::swap(W(i, a), W(i, b));
  for (int i = a + 1; i < b; ++i) std::swap(W(a, i), W(i, b));
  for (int i = b + 1; i < dim; ++i) std::swap(W(a, i), W(b, i));
}

// Pivoted outer-product Cholesky in place: P^T W P = U^T U (U in W's upper rows, P in perm),
// stopping at the numerical rank (a pivot below 1e-12 of the unit diagonal carries no
// information: gauge directions, unobserved blocks). Only W's upper triangle is read or written.
// Returns the rank.
int pivoted_cholesky(MatrixMap W, int dim, int* perm) {
  for (int i = 0; i < dim; ++i) perm[i] = i;
  int rank = 0;
  for (int k = 0; k < dim; ++k) {
    int p = k;
    for (int i = k + 1; i < dim; ++i)
      if (W(i, i) > W(p, p)) p = i;
    if (!(W(p, p) > 1e-12)) break;
    if (p != k) {
      swap_symmetric_upper(W, dim, k, p);
      std::swap(perm[k], perm[p]);
    }
    const double ukk = std::sqrt(W(k, k));
    W(k, k) = ukk;
    // Row k's tail, also in a contiguous copy, so that the column updates below run in packets
    // (the same operations per element).
    double u[capacity::kMaxReducedDim];
    for (int i = k + 1; i < dim; ++i) u[i] = W(k, i) /= ukk;
    // The trailing block's upper triangle minus the outer product of row k's tail:
    // W(i, j) -= W(k, i) W(k, j) for k < i <= j.
    const double* const tail[1] = {u + k + 1};
    for (int j = k + 1; j < dim; ++j) sub_scaled_terms<1>(&W(k + 1, j), &u[j], tail, j - k);
    rank = k + 1;
  }
  return rank;
}

// J = U P^T D^1/2 (rows >= rank are zero); J^T r0 = b <=> U^T r0 = P^T D^-1/2 b. F: J's first
// rank rows with the columns in pivot order (U D^1/2 P, upper triangular), row-major, leading
// dimension dim.
void unscale_factor(MatrixMap W, const DenseVector& sqrt_d, const int* perm, int rank,
                    const Eigen::Ref<const Eigen::VectorXd>& b, MatrixMap J, DenseVector& r0, double* F) {
  const int dim = static_cast<int>(sqrt_d.size());
  J.setZero();
  r0.resize(dim);
  r0.setZero();
  for (int k = 0; k < rank; ++k) {
    r0[k] = b[perm[k]] / sqrt_d[perm[k]];
    for (int i = 0; i < k; ++i) r0[k] -= W(i, k) * r0[i];
    r0[k] /= W(k, k);
  }
  for (int j = 0; j < dim; ++j) {
    const int c = perm[j];
    for (int i = 0; i <= j && i < rank; ++i) F[i * dim + j] = J(i, c) = W(i, j) * sqrt_d[c];
    for (int i = j + 1; i < rank; ++i) F[i * dim + j] = 0.0;
  }
}

// H0 = J^T J (W, whole) from F (unscale_factor). Entry (perm[a], perm[b]), a <= b, is the dot
// product of J's columns perm[a] and perm[b] over the rows r <= a (below, column perm[a] is
// zero), summed from row 0 on: the doubles Eigen's dot gives. Rows a and a + 1 go in one packet;
// row a's sum then also takes the zero product F[a + 1][a] F[a + 1][b], which changes nothing
// but the sign of a zero sum. Two columns share each packet's loads.
void information_from_rows(const double* F, int dim, int rank, const int* perm, MatrixMap W) {
  if (rank == 0) {
    W.setZero();
    return;
  }
  auto set = [&](int a, int b, double v) { W(perm[a], perm[b]) = W(perm[b], perm[a]) = v; };
  // Rows a, a + 1 of column b.
  auto rows_pair = [&](int a, int b) {
    const int rows = std::min(a + 2, rank);
    Pair s = load_pair(F + a) * Pair{F[b], F[b]};
    for (int r = 1; r < rows; ++r) s = s + load_pair(F + r * dim + a) * Pair{F[r * dim + b], F[r * dim + b]};
    set(a, b, s[0]);
    set(a + 1, b, s[1]);
  };
  auto diagonal = [&](int a) {
    const int rows = std::min(a + 1, rank);
    double s = F[a] * F[a];
    for (int r = 1; r < rows; ++r) s += F[r * dim + a] * F[r * dim + a];
    set(a, a, s);
  };
  int b = 0;
  for (; b + 2 <= dim; b += 2) {
    int a = 0;
    for (; a + 2 <= b; a += 2) {  // rows a, a + 1 of columns b, b + 1
      const int rows = std::min(a + 2, rank);
      const Pair fa = load_pair(F + a), fb = load_pair(F + b);
      Pair s0 = fa * Pair{fb[0], fb[0]}, s1 = fa * Pair{fb[1], fb[1]};
      for (int r = 1; r < rows; ++r) {
        const Pair ra = load_pair(F + r * dim + a), rb = load_pair(F + r * dim + b);
        s0 = s0 + ra * Pair{rb[0], rb[0]};
        s1 = s1 + ra * Pair{rb[1], rb[1]};
      }
      set(a, b, s0[0]);
      set(a + 1, b, s0[1]);
      set(a, b + 1, s1[0]);
      set(a + 1, b + 1, s1[1]);
    }
    diagonal(b);
    rows_pair(b, b + 1);
  }
  if (b < dim) {
    for (int a = 0; a + 2 <= b; a += 2) rows_pair(a, b);
    diagonal(b);
  }
}

}  // namespace

SolverStatus MarginalPrior::set_from_information(const PriorBlock* blocks, int num_blocks,
                                                 const Eigen::Ref<const Eigen::MatrixXd>& H,
                                                 const Eigen::Ref<const Eigen::VectorXd>& b) {
  clear();
  int dim = 0;
  const SolverStatus st = check_information(blocks, num_blocks, H, b, &dim);
  if (st != SolverStatus::kOk) return st;

  // Jacobi scaling makes the rank test unit-free (poses, velocities and biases differ by many
  // orders of magnitude): Hs = D^-1/2 H D^-1/2 with D = diag(H).
  DenseVector sqrt_d(dim);
  for (int i = 0; i < dim; ++i) sqrt_d[i] = H(i, i) > 0.0 ? std::sqrt(H(i, i)) : 1.0;
  H0_.resize(dim, dim);
  MatrixMap W = H0_.m();  // workspace: the scaled matrix, then its pivoted factor
  for (int j = 0; j < dim; ++j)
    for (int i = 0; i <= j; ++i) {
      W(i, j) = H(i, j) / (sqrt_d[i] * sqrt_d[j]);
      W(j, i) = W(i, j);
    }
  int perm[capacity::kMaxReducedDim];
  const int rank = pivoted_cholesky(W, dim, perm);
  J_.resize(dim, dim);
  MatrixMap J = J_.m();
  rows_.resize(dim, dim);
  unscale_factor(W, sqrt_d, perm, rank, b, J, r0_, rows_.m().data());
  // H0 = J^T J, exactly the information the prior applies.
  information_from_rows(rows_.m().data(), dim, rank, perm, W);

  for (int i = 0; i < num_blocks; ++i) blocks_[i] = blocks[i];
  num_blocks_ = num_blocks;
  dim_ = dim;
  return SolverStatus::kOk;
}

void MarginalPrior::tangent_error(const double* const* x, double* e,
                                  Eigen::Matrix3d* rot_jac) const {
  int k = 0;
  for (int i = 0; i < num_blocks_; ++i) {
    const PriorBlock& pb = blocks_[i];
    manifold_minus(pb.manifold, pb.ambient_size, x[i], pb.x_lin, e + pb.offset);
    if (pb.manifold == ManifoldType::kPose && rot_jac != nullptr)
      rot_jac[k++] =
          so3_right_jacobian_inverse(Eigen::Map<const Eigen::Vector3d>(e + pb.offset + 3));
  }
}

bool MarginalPrior::evaluate(const double* const* x, double* r,
                             const JacobianView* jacobians) const {
  DenseVector e(dim_);
  Eigen::Matrix3d rot_jac[capacity::kMaxReducedBlocks];
  tangent_error(x, e.data(), rot_jac);
  Eigen::Map<DenseVector> r_map(r, dim_);
  r_map = r0_;
  r_map.noalias() += J_.m() * e;
  if (jacobians == nullptr) return r_map.allFinite();
  int k = 0;
  for (int i = 0; i < num_blocks_; ++i) {
    const PriorBlock& pb = blocks_[i];
    const bool pose = pb.manifold == ManifoldType::kPose;
    const JacobianView& jv = jacobians[i];
    if (!jv.wanted()) {
      if (pose) ++k;
      continue;
    }
    for (int row = 0; row < dim_; ++row) {
      double* out = jv.data + row * jv.row_stride;
      for (int c = 0; c < pb.tangent_size; ++c) out[c] = J_.m()(row, pb.offset + c);
      if (pose) {
        Eigen::Map<Eigen::RowVector3d> rot(out + 3);
        rot = J_.m().block<1, 3>(row, pb.offset + 3) * rot_jac[k];
      }
    }
    if (pose) ++k;
  }
  return r_map.allFinite();
}

}  // namespace ums::solver
