#include "core/estimator/bearing_lift.hpp"

#include <catch2/catch.hpp>

#include <memory>

#include <Eigen/Geometry>

#include "core/estimator/bearing_residual.hpp"
#include "core/estimator/relative_pose_cache.hpp"
#include "solver/manifold.hpp"
#include "tests/core/estimator/pose_block.hpp"

namespace {

using ums::test::iso;
using ums::test::set_pose;
using Mat27 = Eigen::Matrix<double, 2, 7, Eigen::RowMajor>;
using Mat37 = Eigen::Matrix<double, 3, 7, Eigen::RowMajor>;

struct Scene {
  double pose_h[7], pose_t[7], ext0[7], ext1[7];
  double rho = 0.25;  // 4 m
  Eigen::Vector3d b_host = Eigen::Vector3d(0.1, -0.05, 1.0).normalized();
  Scene() {
    set_pose(pose_h, {0.1, -0.2, 1.0}, Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())));
    set_pose(pose_t, {0.4, 0.1, 1.1}, Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d(-1, 2, 1).normalized())));
    set_pose(ext0, {0.02, -0.06, 0.01}, Eigen::Quaterniond(Eigen::AngleAxisd(1.5, Eigen::Vector3d(0.1, 0.2, 1).normalized())));
    set_pose(ext1, {0.03, 0.05, 0.0}, Eigen::Quaterniond(Eigen::AngleAxisd(1.52, Eigen::Vector3d(0.1, 0.2, 1).normalized())));
  }
  Eigen::Vector3d point_w(const double* pose, double r) const { return iso(pose) * (iso(ext0) * (b_host / r)); }
};

// d P_w / d (pose_h tangent, rho) by central differences through the solver's own plus.
Mat37 numeric_g(const Scene& s) {
  Mat37 G;
  const double h = 1e-6;
  for (int k = 0; k < 6; ++k) {
    double d[6] = {0, 0, 0, 0, 0, 0}, xp[7], xm[7];
    d[k] = h;
    ums::solver::manifold_plus(ums::solver::ManifoldType::kPose, 7, s.pose_h, d, xp);
    d[k] = -h;
    ums::solver::manifold_plus(ums::solver::ManifoldType::kPose, 7, s.pose_h, d, xm);
    G.col(k) = (s.point_w(xp, s.rho) - s.point_w(xm, s.rho)) / (2 * h);
  }
  G.col(6) = (s.point_w(s.pose_h, s.rho + h) - s.point_w(s.pose_h, s.rho - h)) / (2 * h);
  return G;
}

// The residual's direct [J_h | J_rho] and its point Jacobian A (d r / d P_w).
void direct_and_point(const ums::BearingResidual& r, const double* const* p, int k_rho, Mat27* J,
                      Eigen::Matrix<double, 2, 3, Eigen::RowMajor>* A) {
  double res[2], jh[12], jt[12], jrho[2], ja[6];
  ums::solver::JacobianView views[5];
  views[0] = {jh, 6};
  views[1] = {jt, 6};
  views[k_rho] = {jrho, 1};
  REQUIRE(r.evaluate(p, res, views));
  J->leftCols<6>() = Eigen::Map<Eigen::Matrix<double, 2, 6, Eigen::RowMajor>>(jh);
  J->col(6) = Eigen::Map<Eigen::Vector2d>(jrho);
  views[0] = {ja, 3, true};
  views[k_rho] = {};
  REQUIRE(r.evaluate(p, res, views));
  *A = Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>>(ja);
}

}  // namespace

TEST_CASE("bearing lift: G is d P_w / d (host pose, rho) by central differences", "[estimator]") {
  Scene s;
  ums::BearingLift lift;
  lift.set(s.b_host * 3.0);  // any length: the lift normalizes as the residual does
  const double* p[] = {s.pose_h, &s.rho, s.ext0};
  Mat37 G;
  REQUIRE(lift.evaluate(p, G.data()));
  CHECK((G - numeric_g(s)).cwiseAbs().maxCoeff() < 1e-6);
  // Rotating the body moves a 4 m point by metres per radian: the check is not vacuous.
  CHECK(G.block<3, 3>(0, 3).norm() > 1.0);
  double bad = -0.1;
  const double* q[] = {s.pose_h, &bad, s.ext0};
  CHECK_FALSE(lift.evaluate(q, G.data()));
}

TEST_CASE("bearing lift: the residual's point Jacobian times G is its host and inverse-depth Jacobian", "[estimator]") {
  Scene s;
  ums::BearingLift lift;
  lift.set(s.b_host);
  const double* pl[] = {s.pose_h, &s.rho, s.ext0};
  Mat37 G;
  REQUIRE(lift.evaluate(pl, G.data()));
  const double w = 460.0 / 1.5;
  const Eigen::Vector3d seen = (iso(s.ext1).inverse() * (iso(s.pose_t).inverse() * s.point_w(s.pose_h, s.rho))).normalized();
  const Eigen::Vector3d b_t = (seen + Eigen::Vector3d(0.01, -0.02, 0.005)).normalized();
  ums::BearingResidual r;
  r.set(ums::BearingResidual::Kind::kTwoFrames, false, s.b_host, b_t, w);
  const double* p[] = {s.pose_h, s.pose_t, s.ext0, s.ext1, &s.rho};
  Mat27 J;
  Eigen::Matrix<double, 2, 3, Eigen::RowMajor> A;

  SECTION("uncached evaluation") {
    direct_and_point(r, p, 4, &J, &A);
    CHECK((A * G - J).cwiseAbs().maxCoeff() < 1e-9 * J.cwiseAbs().maxCoeff());
    CHECK(J.cwiseAbs().maxCoeff() > 10.0);
  }
  SECTION("evaluation from the relative-pose cache") {
    auto cache = std::make_unique<ums::RelativePoseCache>();
    cache->bind_frame(0, s.pose_h);
    cache->bind_frame(1, s.pose_t);
    cache->bind_extrinsic(0, s.ext0);
    cache->bind_extrinsic(1, s.ext1);
    cache->prepare_for_evaluation();
    r.bind(cache.get(), 0, 0, 1, 1);
    direct_and_point(r, p, 4, &J, &A);
    CHECK((A * G - J).cwiseAbs().maxCoeff() < 1e-9 * J.cwiseAbs().maxCoeff());
  }
}
