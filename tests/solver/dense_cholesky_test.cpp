#include "solver/dense_cholesky.hpp"

#include <catch2/catch.hpp>
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/QR>
#include <cmath>
#include <limits>
#include <random>

#include "solver/capacity.hpp"

namespace ums::solver {
namespace {

// A random symmetric positive definite matrix with condition number about `cond`.
Eigen::MatrixXd random_spd(std::mt19937& rng, int n, double cond) {
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::MatrixXd M(n, n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) M(i, j) = g(rng);
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(M);
  const Eigen::MatrixXd Q = qr.householderQ();
  Eigen::VectorXd d(n);
  for (int i = 0; i < n; ++i) d[i] = std::pow(cond, n > 1 ? static_cast<double>(i) / (n - 1) : 0.0);
  return Q * d.asDiagonal() * Q.transpose();
}

TEST_CASE("cholesky_upper factors and solves as Eigen's LLT does, to rounding", "[solver][cholesky]") {
  std::mt19937 rng(11);
  for (int n : {1, 2, 3, 4, 5, 6, 7, 13, 66, 72, 101, 192}) {
    const Eigen::MatrixXd A = random_spd(rng, n, 1e6);
    // Leading dimension larger than n, a sentinel in the strict lower triangle and past the rows.
    const long ld = n + 3;
    Eigen::MatrixXd store = Eigen::MatrixXd::Constant(ld, n, 7.5);
    for (int j = 0; j < n; ++j)
      for (int i = 0; i <= j; ++i) store(i, j) = A(i, j);
    REQUIRE(cholesky_upper(store.data(), ld, n));
    Eigen::MatrixXd U = Eigen::MatrixXd::Zero(n, n);
    for (int j = 0; j < n; ++j)
      for (int i = 0; i <= j; ++i) U(i, j) = store(i, j);
    bool untouched = true;
    for (int j = 0; j < n; ++j)
      for (long i = j + 1; i < ld; ++i) untouched = untouched && store(i, j) == 7.5;
    REQUIRE(untouched);
    // U^T U reproduces A to the factorization's backward error.
    const double rel = (U.transpose() * U - A).norm() / A.norm();
    CHECK(rel < 1e-14);
    const Eigen::LLT<Eigen::MatrixXd, Eigen::Upper> ref(A);
    CHECK((U - Eigen::MatrixXd(ref.matrixU())).norm() / U.norm() < 1e-12);
    // The solve: x = A^-1 b against Eigen's, relative error within cond * eps.
    std::normal_distribution<double> g(0.0, 1.0);
    Eigen::VectorXd b(n);
    for (int i = 0; i < n; ++i) b[i] = g(rng);
    Eigen::VectorXd x = b;
    cholesky_solve_upper(store.data(), ld, n, x.data());
    const Eigen::VectorXd x_ref = ref.solve(b);
    CHECK((x - x_ref).norm() / x_ref.norm() < 1e-8);
    CHECK((A * x - b).norm() / b.norm() < 1e-9);
  }
}

TEST_CASE("cholesky_upper refuses matrices that are not positive definite", "[solver][cholesky]") {
  std::mt19937 rng(5);
  const int n = 9;
  Eigen::MatrixXd A = random_spd(rng, n, 10.0);
  SECTION("a negative eigenvalue") {
    A -= 20.0 * Eigen::MatrixXd::Identity(n, n);
    CHECK_FALSE(cholesky_upper(A.data(), n, n));
  }
  SECTION("singular: a zero row and column") {
    A.row(4).setZero();
    A.col(4).setZero();
    CHECK_FALSE(cholesky_upper(A.data(), n, n));
  }
  SECTION("a NaN") {
    A(2, 6) = std::numeric_limits<double>::quiet_NaN();
    CHECK_FALSE(cholesky_upper(A.data(), n, n));
  }
  SECTION("n = 0 is the empty factor") { CHECK(cholesky_upper(A.data(), n, 0)); }
  SECTION("above capacity: refused, untouched") {
    const int big = capacity::kMaxReducedDim + 1;
    Eigen::MatrixXd B = Eigen::MatrixXd::Identity(big, big);
    CHECK_FALSE(cholesky_upper(B.data(), big, big));
    CHECK(B == Eigen::MatrixXd::Identity(big, big));
  }
}

}  // namespace
}  // namespace ums::solver
