#include "solver/marginal_prior.hpp"

#include <catch2/catch.hpp>
#include <memory>
#include <vector>

#include "profiling/solver_bench/vio_window.hpp"

namespace ums::solver {
namespace {

// Two poses and a speed-bias: dim 6 + 9 + 6 = 21.
void make_blocks(PriorBlock* pb) {
  const ManifoldType m[3] = {ManifoldType::kPose, ManifoldType::kEuclidean, ManifoldType::kPose};
  const int amb[3] = {7, 9, 7};
  int off = 0;
  for (int i = 0; i < 3; ++i) {
    pb[i].manifold = m[i];
    pb[i].ambient_size = amb[i];
    pb[i].tangent_size = tangent_size(m[i], amb[i]);
    pb[i].offset = off;
    off += pb[i].tangent_size;
    for (int k = 0; k < amb[i]; ++k) pb[i].x_lin[k] = 0.1 * (k + 1) * (i + 1);
    if (m[i] == ManifoldType::kPose) {
      const Eigen::Quaterniond q = so3_exp(Eigen::Vector3d(0.1 * i, -0.2, 0.3));
      pb[i].x_lin[3] = q.x(); pb[i].x_lin[4] = q.y(); pb[i].x_lin[5] = q.z(); pb[i].x_lin[6] = q.w();
    }
  }
}

TEST_CASE("Square-root prior reproduces H and b, also when rank-deficient", "[solver][prior]") {
  bench::Rng rng(11);
  PriorBlock pb[3];
  make_blocks(pb);
  const int n = 21;
  for (const int rank : {21, 17}) {
    Eigen::MatrixXd A(rank, n);
    for (int r = 0; r < rank; ++r)
      for (int c = 0; c < n; ++c) A(r, c) = rng.normal() * (c < 6 ? 100.0 : 1.0);  // mixed scales
    const Eigen::MatrixXd H = A.transpose() * A;
    Eigen::VectorXd z(rank);
    for (int r = 0; r < rank; ++r) z[r] = rng.normal();
    const Eigen::VectorXd b = A.transpose() * z;  // b in the range of H, as marginalization gives
    auto prior = std::make_unique<MarginalPrior>();
    REQUIRE(prior->set_from_information(pb, 3, H, b) == SolverStatus::kOk);
    const Eigen::MatrixXd J = prior->sqrt_information();
    const double h_err = (J.transpose() * J - H).norm() / H.norm();
    const double b_err = (J.transpose() * prior->r0() - b).norm() / b.norm();
    INFO("rank " << rank << " |J^T J - H|/|H| " << h_err << " |J^T r0 - b|/|b| " << b_err);
    CHECK(h_err < 1e-12);
    CHECK(b_err < 1e-9);
    CHECK((prior->information() - J.transpose() * J).norm() <= 1e-12 * H.norm());
    // Rows beyond the numerical rank carry nothing.
    CHECK(J.bottomRows(n - rank).norm() == 0.0);
  }
  // NaN information is refused.
  Eigen::MatrixXd H = Eigen::MatrixXd::Identity(n, n);
  H(3, 5) = std::numeric_limits<double>::quiet_NaN();
  auto prior = std::make_unique<MarginalPrior>();
  CHECK(prior->set_from_information(pb, 3, H, Eigen::VectorXd::Zero(n)) == SolverStatus::kInvalidInput);
}

TEST_CASE("Prior residual is r0 at x_lin and its Jacobians match central differences",
          "[solver][prior]") {
  bench::Rng rng(5);
  PriorBlock pb[3];
  make_blocks(pb);
  const int n = 21;
  Eigen::MatrixXd A(n, n);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) A(r, c) = rng.normal();
  const Eigen::MatrixXd H = A.transpose() * A + Eigen::MatrixXd::Identity(n, n);
  Eigen::VectorXd b(n);
  for (int k = 0; k < n; ++k) b[k] = rng.normal();
  auto prior = std::make_unique<MarginalPrior>();
  REQUIRE(prior->set_from_information(pb, 3, H, b) == SolverStatus::kOk);

  double x[3][9];
  const double* xs[3] = {x[0], x[1], x[2]};
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 9; ++k) x[i][k] = pb[i].x_lin[k];
  Eigen::VectorXd r(n);
  REQUIRE(prior->evaluate(xs, r.data(), nullptr));
  CHECK((r - prior->r0()).norm() < 1e-15);

  // Away from x_lin (rotations of 0.3 rad) the Jacobian includes Jr^-1.
  const double step[6] = {0.1, -0.2, 0.05, 0.2, -0.3, 0.1};
  manifold_plus(ManifoldType::kPose, 7, pb[0].x_lin, step, x[0]);
  manifold_plus(ManifoldType::kPose, 7, pb[2].x_lin, step, x[2]);
  double jac[3][21 * 9];
  JacobianView views[3] = {{jac[0], 6}, {jac[1], 9}, {jac[2], 6}};
  REQUIRE(prior->evaluate(xs, r.data(), views));
  double worst = 0.0;
  for (int i = 0; i < 3; ++i) {
    for (int c = 0; c < pb[i].tangent_size; ++c) {
      double d[9] = {};
      double keep[9];
      for (int k = 0; k < 9; ++k) keep[k] = x[i][k];
      Eigen::VectorXd rp(n), rm(n);
      d[c] = 1e-6;
      manifold_plus(pb[i].manifold, pb[i].ambient_size, keep, d, x[i]);
      prior->evaluate(xs, rp.data(), nullptr);
      d[c] = -1e-6;
      manifold_plus(pb[i].manifold, pb[i].ambient_size, keep, d, x[i]);
      prior->evaluate(xs, rm.data(), nullptr);
      for (int k = 0; k < 9; ++k) x[i][k] = keep[k];
      for (int row = 0; row < n; ++row) {
        const double num = (rp[row] - rm[row]) / 2e-6;
        worst = std::max(worst, std::abs(num - jac[i][row * pb[i].tangent_size + c]));
      }
    }
  }
  INFO("worst Jacobian error " << worst);
  CHECK(worst < 1e-7);
}

// The factor as the plain loops formed it before its trailing update ran in packets
// (marginal_prior.cpp): J = U P^T D^1/2 of the Jacobi-scaled H, pivoted, to the numerical rank,
// and r0 from U^T r0 = P^T D^-1/2 b.
struct Factor {
  Eigen::MatrixXd J;
  Eigen::VectorXd r0;
};
Factor reference_factor(const Eigen::MatrixXd& H, const Eigen::VectorXd& b) {
  const int dim = static_cast<int>(H.rows());
  Eigen::VectorXd sqrt_d(dim);
  for (int i = 0; i < dim; ++i) sqrt_d[i] = H(i, i) > 0.0 ? std::sqrt(H(i, i)) : 1.0;
  Eigen::MatrixXd W(dim, dim);
  for (int j = 0; j < dim; ++j)
    for (int i = 0; i <= j; ++i) W(i, j) = W(j, i) = H(i, j) / (sqrt_d[i] * sqrt_d[j]);
  std::vector<int> perm(dim);
  for (int i = 0; i < dim; ++i) perm[i] = i;
  int rank = 0;
  for (int k = 0; k < dim; ++k) {
    int p = k;
    for (int i = k + 1; i < dim; ++i)
      if (W(i, i) > W(p, p)) p = i;
    if (!(W(p, p) > 1e-12)) break;
    if (p != k) {  // a symmetric swap of rows and columns k, p (both triangles kept here)
      W.row(k).swap(W.row(p));
      W.col(k).swap(W.col(p));
      std::swap(perm[k], perm[p]);
    }
    const double ukk = std::sqrt(W(k, k));
    W(k, k) = ukk;
    for (int i = k + 1; i < dim; ++i) W(k, i) /= ukk;
    for (int j = k + 1; j < dim; ++j)
      for (int i = k + 1; i <= j; ++i) W(i, j) -= W(k, i) * W(k, j);
    for (int j = k + 1; j < dim; ++j)
      for (int i = j + 1; i < dim; ++i) W(i, j) = W(j, i);
    rank = k + 1;
  }
  Factor f{Eigen::MatrixXd::Zero(dim, dim), Eigen::VectorXd::Zero(dim)};
  for (int k = 0; k < rank; ++k) {
    f.r0[k] = b[perm[k]] / sqrt_d[perm[k]];
    for (int i = 0; i < k; ++i) f.r0[k] -= W(i, k) * f.r0[i];
    f.r0[k] /= W(k, k);
  }
  for (int j = 0; j < dim; ++j)
    for (int i = 0; i <= j && i < rank; ++i) f.J(i, perm[j]) = W(i, j) * sqrt_d[perm[j]];
  return f;
}

TEST_CASE("The factor's packet update gives the plain loops' doubles", "[solver][prior]") {
  bench::Rng rng(5);
  PriorBlock pb[3];
  make_blocks(pb);
  const int n = 21;  // a column update of odd length (j - k) ends in a scalar element
  for (const int rank : {21, 13}) {
    Eigen::MatrixXd A(rank, n);
    for (int r = 0; r < rank; ++r)
      for (int c = 0; c < n; ++c) A(r, c) = rng.normal() * (c % 5 == 0 ? 30.0 : 1.0);
    const Eigen::MatrixXd H = A.transpose() * A;
    Eigen::VectorXd z(rank);
    for (int r = 0; r < rank; ++r) z[r] = rng.normal();
    const Eigen::VectorXd b = A.transpose() * z;
    auto prior = std::make_unique<MarginalPrior>();
    REQUIRE(prior->set_from_information(pb, 3, H, b) == SolverStatus::kOk);
    const Eigen::MatrixXd J = prior->sqrt_information();
    const Factor ref = reference_factor(H, b);
    int differ = 0;
    for (int j = 0; j < n; ++j) {
      differ += prior->r0()[j] != ref.r0[j];
      for (int i = 0; i < n; ++i) differ += J(i, j) != ref.J(i, j);
    }
    INFO("rank " << rank << ", |J - J_ref| " << (J - ref.J).norm() << ", |r0 - r0_ref| " << (prior->r0() - ref.r0).norm());
    CHECK(differ == 0);
  }
}

// Blocks of the given manifolds (pose: ambient 7, else Euclidean of `euclid` each), consecutive.
int layout_blocks(const std::vector<ManifoldType>& kinds, int euclid, PriorBlock* pb) {
  int off = 0;
  for (std::size_t i = 0; i < kinds.size(); ++i) {
    pb[i] = PriorBlock{};
    pb[i].manifold = kinds[i];
    pb[i].ambient_size = kinds[i] == ManifoldType::kPose ? 7 : euclid;
    pb[i].tangent_size = tangent_size(kinds[i], pb[i].ambient_size);
    pb[i].offset = off;
    pb[i].x_lin[6] = 1.0;
    off += pb[i].tangent_size;
  }
  return off;
}

TEST_CASE("The prior's information is J^T J entry by entry, as the columns' dot products give it", "[solver][prior]") {
  // H0 is formed two pivot rows and two columns at a time (information_from_rows); every entry
  // must be the sequential dot product of two columns of J (the rows past the shorter column's
  // end add exact zeros), for even and odd dimensions, full and deficient rank, and rank 0.
  bench::Rng rng(17);
  const ManifoldType P = ManifoldType::kPose, E = ManifoldType::kEuclidean;
  const std::vector<std::vector<ManifoldType>> layouts = {{P, P}, {P, E, P}, {E, P, P, E}, {P}};
  // One prior for all, as the marginalizer reuses its two: a read past the rank would find the
  // last case's numbers, not zeros.
  auto prior = std::make_unique<MarginalPrior>();
  for (const auto& kinds : layouts) {
    PriorBlock pb[4];
    const int n = layout_blocks(kinds, 9, pb);
    for (const int rank : {n, n - 5, 1, 0}) {
      Eigen::MatrixXd A = Eigen::MatrixXd::Zero(std::max(rank, 1), n);
      for (int r = 0; r < rank; ++r)
        for (int c = 0; c < n; ++c) A(r, c) = rng.normal() * (c % 7 == 0 ? 40.0 : 1.0);
      const Eigen::MatrixXd H = A.transpose() * A;
      const Eigen::VectorXd b = A.transpose() * Eigen::VectorXd::Ones(A.rows());
      REQUIRE(prior->set_from_information(pb, static_cast<int>(kinds.size()), H, b) == SolverStatus::kOk);
      const Eigen::MatrixXd J = prior->sqrt_information();
      const Eigen::MatrixXd H0 = prior->information();
      int differ = 0;
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          double s = J(0, i) * J(0, j);
          for (int r = 1; r < n; ++r) s += J(r, i) * J(r, j);
          differ += H0(i, j) != s;
        }
      INFO("dim " << n << ", rank " << rank << ", |H0 - J^T J| " << (H0 - J.transpose() * J).norm());
      CHECK(differ == 0);
      CHECK((H0 - H).norm() <= 1e-10 * (1.0 + H.norm()));
    }
  }
}

}  // namespace
}  // namespace ums::solver
