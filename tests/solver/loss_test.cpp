#include "solver/loss.hpp"

#include <catch2/catch.hpp>
#include <cmath>

namespace ums::solver {
namespace {

TEST_CASE("Huber and Cauchy values and derivatives", "[solver][loss]") {
  const RobustLoss losses[] = {RobustLoss::huber(1.5), RobustLoss::cauchy(0.7), RobustLoss::trivial()};
  for (const RobustLoss& loss : losses) {
    for (double s : {0.1, 1.0, 2.0, 9.0, 100.0}) {
      double rho[3], rp[3], rm[3];
      const double h = 1e-6 * s;
      loss.evaluate(s, rho);
      loss.evaluate(s + h, rp);
      loss.evaluate(s - h, rm);
      CHECK(rho[1] == Approx((rp[0] - rm[0]) / (2 * h)).epsilon(1e-6));
      CHECK(rho[2] == Approx((rp[1] - rm[1]) / (2 * h)).epsilon(1e-4).margin(1e-9));
    }
  }
  double rho[3];
  RobustLoss::huber(1.0).evaluate(9.0, rho);  // |r| = 3 > 1: 2*1*3 - 1
  CHECK(rho[0] == Approx(5.0));
  RobustLoss::cauchy(2.0).evaluate(4.0, rho);  // 4 log(2)
  CHECK(rho[0] == Approx(4.0 * std::log(2.0)));
}

TEST_CASE("Corrected residual and Jacobian give the robust gradient", "[solver][loss]") {
  // For any loss, J'^T r' must equal rho'(s) J^T r (the gradient of 0.5 rho(|r|^2)).
  const double r0[2] = {3.0, -2.0};
  const double J0[2 * 3] = {1.0, 0.5, -0.2, 0.3, -1.0, 0.7};
  for (const RobustLoss& loss : {RobustLoss::huber(1.0), RobustLoss::cauchy(1.0)}) {
    double r[2] = {r0[0], r0[1]};
    double J[6];
    for (int i = 0; i < 6; ++i) J[i] = J0[i];
    const double s = r[0] * r[0] + r[1] * r[1];
    double rho[3];
    loss.evaluate(s, rho);
    LossCorrector c(s, rho);
    c.correct_jacobian(2, 3, 3, r, J);
    c.correct_residual(2, r);
    for (int col = 0; col < 3; ++col) {
      const double g = J[col] * r[0] + J[3 + col] * r[1];
      const double g_expected = rho[1] * (J0[col] * r0[0] + J0[3 + col] * r0[1]);
      CHECK(g == Approx(g_expected).epsilon(1e-12));
    }
  }
}

}  // namespace
}  // namespace ums::solver
