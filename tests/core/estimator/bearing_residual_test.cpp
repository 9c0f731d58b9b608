#include "core/estimator/bearing_residual.hpp"

#include <catch2/catch.hpp>

#include <memory>

#include <Eigen/Geometry>

#include "tests/core/estimator/jacobian_check.hpp"
#include "tests/core/estimator/pose_block.hpp"

namespace {

using ums::test::iso;
using ums::test::set_pose;

struct Scene {
  double pose_h[7], pose_t[7], ext0[7], ext1[7];
  double rho = 0.25;  // 4 m
  Eigen::Vector3d b_host;
  Scene() {
    set_pose(pose_h, {0.1, -0.2, 1.0}, Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())));
    set_pose(pose_t, {0.4, 0.1, 1.1}, Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d(-1, 2, 1).normalized())));
    set_pose(ext0, {0.02, -0.06, 0.01}, Eigen::Quaterniond(Eigen::AngleAxisd(1.5, Eigen::Vector3d(0.1, 0.2, 1).normalized())));
    set_pose(ext1, {0.03, 0.05, 0.0}, Eigen::Quaterniond(Eigen::AngleAxisd(1.52, Eigen::Vector3d(0.1, 0.2, 1).normalized())));
    b_host = Eigen::Vector3d(0.1, -0.05, 1.0).normalized();
  }
  // Bearing at which the target camera sees the landmark.
  Eigen::Vector3d truth(bool same_frame, const double* ext_t) const {
    const Eigen::Vector3d P_bh = iso(ext0) * (b_host / rho);
    const Eigen::Vector3d P_bt = same_frame ? P_bh : Eigen::Vector3d(iso(pose_t).inverse() * (iso(pose_h) * P_bh));
    return (iso(ext_t).inverse() * P_bt).normalized();
  }
};

}  // namespace

TEST_CASE("bearing residual is zero at the truth and its Jacobians match central differences", "[estimator]") {
  Scene s;
  const double w = 460.0 / 1.5;
  ums::BearingResidual r;
  double res[2];

  SECTION("two frames, same camera") {
    r.set(ums::BearingResidual::Kind::kTwoFrames, true, s.b_host, s.truth(false, s.ext0), w);
    const double* p[] = {s.pose_h, s.pose_t, s.ext0, &s.rho};
    REQUIRE(r.evaluate(p, res, nullptr));
    CHECK(std::hypot(res[0], res[1]) < 1e-9);
    const Eigen::Vector3d noisy = (s.truth(false, s.ext0) + Eigen::Vector3d(0.01, -0.02, 0.0)).normalized();
    r.set(ums::BearingResidual::Kind::kTwoFrames, true, s.b_host, noisy, w);
    CHECK(ums::test::max_jacobian_error(r, {{s.pose_h, 7, true}, {s.pose_t, 7, true}, {s.ext0, 7, true}, {&s.rho, 1, false}}) < 1e-6);
  }
  SECTION("two frames, other camera") {
    r.set(ums::BearingResidual::Kind::kTwoFrames, false, s.b_host, s.truth(false, s.ext1), w);
    const double* p[] = {s.pose_h, s.pose_t, s.ext0, s.ext1, &s.rho};
    REQUIRE(r.evaluate(p, res, nullptr));
    CHECK(std::hypot(res[0], res[1]) < 1e-9);
    const Eigen::Vector3d noisy = (s.truth(false, s.ext1) + Eigen::Vector3d(-0.01, 0.01, 0.02)).normalized();
    r.set(ums::BearingResidual::Kind::kTwoFrames, false, s.b_host, noisy, w);
    CHECK(ums::test::max_jacobian_error(
              r, {{s.pose_h, 7, true}, {s.pose_t, 7, true}, {s.ext0, 7, true}, {s.ext1, 7, true}, {&s.rho, 1, false}}) < 1e-6);
  }
  SECTION("stereo pair of the host frame") {
    r.set(ums::BearingResidual::Kind::kSameFrame, false, s.b_host, s.truth(true, s.ext1), w);
    const double* p[] = {s.ext0, s.ext1, &s.rho};
    REQUIRE(r.evaluate(p, res, nullptr));
    CHECK(std::hypot(res[0], res[1]) < 1e-9);
    const Eigen::Vector3d noisy = (s.truth(true, s.ext1) + Eigen::Vector3d(0.02, 0.0, -0.01)).normalized();
    r.set(ums::BearingResidual::Kind::kSameFrame, false, s.b_host, noisy, w);
    CHECK(ums::test::max_jacobian_error(r, {{s.ext0, 7, true}, {s.ext1, 7, true}, {&s.rho, 1, false}}) < 1e-6);
  }
}

TEST_CASE("bearing residual: 1 px of image error is 1 / sigma after whitening, behind the camera is refused", "[estimator]") {
  Scene s;
  const double f_px = 460.0, sigma_px = 1.5;
  const Eigen::Vector3d b = s.truth(false, s.ext0);
  // Rotate the measured bearing by 1 px worth of angle.
  const Eigen::Vector3d axis = b.cross(Eigen::Vector3d::UnitX()).normalized();
  const Eigen::Vector3d b_off = Eigen::AngleAxisd(1.0 / f_px, axis) * b;
  ums::BearingResidual r;
  r.set(ums::BearingResidual::Kind::kTwoFrames, true, s.b_host, b_off, f_px / sigma_px);
  const double* p[] = {s.pose_h, s.pose_t, s.ext0, &s.rho};
  double res[2];
  REQUIRE(r.evaluate(p, res, nullptr));
  CHECK(std::hypot(res[0], res[1]) == Approx(1.0 / sigma_px).epsilon(1e-4));
  double e_rad = 0.0;
  REQUIRE(r.error_rad(p, &e_rad));
  CHECK(e_rad * f_px == Approx(1.0).epsilon(1e-4));
  s.rho = -0.25;  // negative inverse depth: not a point in front of the host
  CHECK_FALSE(r.evaluate(p, res, nullptr));
}

TEST_CASE("bearing residual bound to the pose cache: same values and Jacobians, follows moved poses", "[estimator]") {
  Scene s;
  const double w = 460.0 / 1.5;
  auto cache = std::make_unique<ums::RelativePoseCache>();
  cache->bind_frame(3, s.pose_h);
  cache->bind_frame(7, s.pose_t);
  cache->bind_extrinsic(0, s.ext0);
  cache->bind_extrinsic(1, s.ext1);
  for (const bool same_cam : {true, false}) {
    const double* ext_t = same_cam ? s.ext0 : s.ext1;
    const Eigen::Vector3d noisy = (s.truth(false, ext_t) + Eigen::Vector3d(0.01, -0.02, 0.01)).normalized();
    ums::BearingResidual plain, bound;
    plain.set(ums::BearingResidual::Kind::kTwoFrames, same_cam, s.b_host, noisy, w);
    bound.set(ums::BearingResidual::Kind::kTwoFrames, same_cam, s.b_host, noisy, w);
    bound.bind(cache.get(), 3, 0, 7, same_cam ? 0 : 1);
    const double* p4[] = {s.pose_h, s.pose_t, s.ext0, &s.rho};
    const double* p5[] = {s.pose_h, s.pose_t, s.ext0, s.ext1, &s.rho};
    const double* const* p = same_cam ? p4 : p5;
    const int nb = same_cam ? 4 : 5;
    for (int round = 0; round < 2; ++round) {
      // Jacobians of the poses and the inverse depth only (the extrinsics are constant in a solve).
      double jp[5][12] = {}, jb[5][12] = {};
      ums::solver::JacobianView vp[5], vb[5];
      for (int k = 0; k < nb; ++k) {
        const bool want = k < 2 || k == nb - 1;
        const int cols = k == nb - 1 ? 1 : 6;
        vp[k] = {want ? jp[k] : nullptr, cols};
        vb[k] = {want ? jb[k] : nullptr, cols};
      }
      double rp[2], rb[2];
      REQUIRE(plain.evaluate(p, rp, vp));
      REQUIRE(bound.evaluate(p, rb, vb));
      CHECK(std::abs(rp[0] - rb[0]) < 1e-9);  // whitened units: 1e-9 of sigma
      CHECK(std::abs(rp[1] - rb[1]) < 1e-9);
      double worst = 0.0;
      for (int k = 0; k < nb; ++k)
        for (int i = 0; i < 12; ++i) worst = std::max(worst, std::abs(jp[k][i] - jb[k][i]));
      CHECK(worst < 1e-8);
      // Residual without Jacobians takes the same cached path.
      REQUIRE(bound.evaluate(p, rb, nullptr));
      CHECK(std::abs(rp[0] - rb[0]) < 1e-9);
      // The solver moves the target pose in place and invalidates the cache (its callback).
      s.pose_t[0] += 0.05;
      s.pose_t[4] += 0.01;
      Eigen::Map<Eigen::Quaterniond>(s.pose_t + 3).normalize();
      cache->prepare_for_evaluation();
      if (round == 0) {
        double before[2];
        REQUIRE(plain.evaluate(p, before, nullptr));
        CHECK(std::hypot(before[0] - rp[0], before[1] - rp[1]) > 1.0);  // it did move the residual
      }
    }
  }
}

TEST_CASE("bearing residual of the host frame's stereo pair bound to the cache: same values, follows moved extrinsics",
          "[estimator]") {
  Scene s;
  const double w = 460.0 / 1.5;
  auto cache = std::make_unique<ums::RelativePoseCache>();
  cache->bind_extrinsic(0, s.ext0);
  cache->bind_extrinsic(1, s.ext1);
  const Eigen::Vector3d noisy = (s.truth(true, s.ext1) + Eigen::Vector3d(0.01, 0.01, -0.02)).normalized();
  ums::BearingResidual plain, bound;
  plain.set(ums::BearingResidual::Kind::kSameFrame, false, s.b_host, noisy, w);
  bound.set(ums::BearingResidual::Kind::kSameFrame, false, s.b_host, noisy, w);
  bound.bind(cache.get(), 3, 0, 3, 1);
  const double* p[] = {s.ext0, s.ext1, &s.rho};
  for (int round = 0; round < 2; ++round) {
    double jp[2] = {}, jb[2] = {}, rp[2], rb[2];
    ums::solver::JacobianView vp[3] = {{}, {}, {jp, 1}}, vb[3] = {{}, {}, {jb, 1}};
    REQUIRE(plain.evaluate(p, rp, vp));
    REQUIRE(bound.evaluate(p, rb, vb));
    CHECK(std::hypot(rp[0] - rb[0], rp[1] - rb[1]) < 1e-9);
    CHECK(std::hypot(jp[0] - jb[0], jp[1] - jb[1]) < 1e-8 * std::hypot(jp[0], jp[1]));
    CHECK(std::hypot(jp[0], jp[1]) > 1.0);
    // An estimated extrinsic moves in place; the solver's callback invalidates the cache.
    s.ext1[0] += 0.01;
    cache->prepare_for_evaluation();
    if (round == 0) {
      double moved[2];
      REQUIRE(plain.evaluate(p, moved, nullptr));
      CHECK(std::hypot(moved[0] - rp[0], moved[1] - rp[1]) > 0.1);
    }
  }
}

TEST_CASE("bearing residual with a time offset: bearings moved along their velocities, zero at the true offset",
          "[estimator][td]") {
  Scene s;
  const double w = 460.0 / 1.5;
  // The images were taken 12 ms after the frames' stamps (td 12 ms, the stamps corrected by 0):
  // each measured bearing is the true one 12 ms later, b + 0.012 v.
  const double td_true_s = 0.012, td_applied_s = 0.0;
  const Eigen::Vector3d v_host(0.4, -0.2, -0.02);  // 1/s, about 0.45 rad/s of image motion
  const Eigen::Vector3d v_target(-0.3, 0.5, 0.01);
  const Eigen::Vector3d b_host_meas = (s.b_host + td_true_s * v_host).normalized();
  auto cache = std::make_unique<ums::RelativePoseCache>();
  cache->bind_frame(3, s.pose_h);
  cache->bind_frame(7, s.pose_t);
  cache->bind_extrinsic(0, s.ext0);
  cache->bind_extrinsic(1, s.ext1);

  for (const bool same_cam : {true, false}) {
    const double* ext_t = same_cam ? s.ext0 : s.ext1;
    const Eigen::Vector3d b_t_meas = s.truth(false, ext_t) + td_true_s * v_target;
    // The host bearing's shift is first order: the landmark sits on the moved ray.
    ums::BearingResidual r;
    r.set(ums::BearingResidual::Kind::kTwoFrames, same_cam, b_host_meas, b_t_meas.normalized(), w);
    r.set_time_offset(v_host, v_target, td_applied_s, td_applied_s);
    CHECK(r.num_blocks() == (same_cam ? 5 : 6));
    double td = td_true_s;
    const double* p5[] = {s.pose_h, s.pose_t, s.ext0, &s.rho, &td};
    const double* p6[] = {s.pose_h, s.pose_t, s.ext0, s.ext1, &s.rho, &td};
    const double* const* p = same_cam ? p5 : p6;
    double err_true = 0.0, err_zero = 0.0;
    REQUIRE(r.error_rad(p, &err_true));
    td = 0.0;
    REQUIRE(r.error_rad(p, &err_zero));
    // At the true offset only second-order terms are left (|0.012 v|^2 ~ 3e-5 rad ~ 0.01 px);
    // ignoring it leaves about 0.012 * |v_t - v_h moved| ~ 7 mrad (3 px).
    CHECK(err_true * 460.0 < 0.05);
    CHECK(err_zero * 460.0 > 1.0);
    td = 0.005;
    std::vector<ums::test::BlockSpec> blocks = {{s.pose_h, 7, true}, {s.pose_t, 7, true}, {s.ext0, 7, true}};
    if (!same_cam) blocks.push_back({s.ext1, 7, true});
    blocks.push_back({&s.rho, 1, false});
    blocks.push_back({&td, 1, false});
    CHECK(ums::test::max_jacobian_error(r, blocks) < 1e-6);
    // The cached path (poses from the pose cache) gives the same residual and td Jacobian.
    ums::BearingResidual bound = r;
    bound.bind(cache.get(), 3, 0, 7, same_cam ? 0 : 1);
    cache->prepare_for_evaluation();
    const int nb = r.num_blocks();
    double jp[6][12] = {}, jb[6][12] = {};
    ums::solver::JacobianView vp[6], vb[6];
    for (int k = 0; k < nb; ++k) {
      const bool want = k < 2 || k >= nb - 2;  // poses, inverse depth, td (extrinsics constant)
      const int cols = k >= nb - 2 ? 1 : 6;
      vp[k] = {want ? jp[k] : nullptr, cols};
      vb[k] = {want ? jb[k] : nullptr, cols};
    }
    double rp[2], rb[2];
    REQUIRE(r.evaluate(p, rp, vp));
    REQUIRE(bound.evaluate(p, rb, vb));
    CHECK(std::abs(rp[0] - rb[0]) < 1e-9);
    CHECK(std::abs(rp[1] - rb[1]) < 1e-9);
    CHECK(std::abs(jp[nb - 1][0] - jb[nb - 1][0]) < 1e-8);
    CHECK(std::abs(jp[nb - 1][1] - jb[nb - 1][1]) < 1e-8);
  }
  SECTION("stereo pair of the host frame") {
    const Eigen::Vector3d b_t_meas = s.truth(true, s.ext1) + td_true_s * v_target;
    ums::BearingResidual r;
    r.set(ums::BearingResidual::Kind::kSameFrame, false, b_host_meas, b_t_meas.normalized(), w);
    r.set_time_offset(v_host, v_target, td_applied_s, td_applied_s);
    double td = td_true_s;
    const double* p[] = {s.ext0, s.ext1, &s.rho, &td};
    double err = 0.0;
    REQUIRE(r.error_rad(p, &err));
    CHECK(err * 460.0 < 0.05);
    td = -0.004;
    CHECK(ums::test::max_jacobian_error(r, {{s.ext0, 7, true}, {s.ext1, 7, true}, {&s.rho, 1, false}, {&td, 1, false}}) <
          1e-6);
  }
}

TEST_CASE("bearing residual with a time offset: host and target frames each carry their own applied offset",
          "[estimator][td]") {
  Scene s;
  const double w = 460.0 / 1.5;
  // The host frame went out before td was known (stamp corrected by 0), the target after the
  // pipeline had restamped by the estimate (12 ms): only the host bearing is 12 ms late.
  const double td_true_s = 0.012, applied_host_s = 0.0, applied_target_s = 0.012;
  const Eigen::Vector3d v_host(0.4, -0.2, -0.02), v_target(-0.3, 0.5, 0.01);  // 1/s
  const Eigen::Vector3d b_host_meas = (s.b_host + (td_true_s - applied_host_s) * v_host).normalized();
  const Eigen::Vector3d b_t_meas =
      (s.truth(false, s.ext0) + (td_true_s - applied_target_s) * v_target).normalized();
  double td = td_true_s;
  const double* p[] = {s.pose_h, s.pose_t, s.ext0, &s.rho, &td};
  ums::BearingResidual own;
  own.set(ums::BearingResidual::Kind::kTwoFrames, true, b_host_meas, b_t_meas, w);
  own.set_time_offset(v_host, v_target, applied_host_s, applied_target_s);
  ums::BearingResidual shared = own;  // both read as the host's 0
  shared.set_time_offset(v_host, v_target, applied_host_s, applied_host_s);
  double err_own = 0.0, err_shared = 0.0;
  REQUIRE(own.error_rad(p, &err_own));
  REQUIRE(shared.error_rad(p, &err_shared));
  CHECK(err_own * 460.0 < 0.05);    // px: second order only
  CHECK(err_shared * 460.0 > 1.0);  // px: 12 ms of the target's 0.58 rad/s motion is 3 px
  td = 0.007;
  CHECK(ums::test::max_jacobian_error(own, {{s.pose_h, 7, true}, {s.pose_t, 7, true}, {s.ext0, 7, true},
                                            {&s.rho, 1, false}, {&td, 1, false}}) < 1e-6);
}
