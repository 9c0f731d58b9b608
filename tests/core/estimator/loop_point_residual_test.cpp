// The loop keyframe's stereo point seen by a window frame (core/estimator/loop_point_residual.hpp):
// zero where the point projects onto the measured bearing, 1 px of image error is 1 / sigma after
// whitening, and its Jacobians (the bearing residual's, without the inverse distance) match
// central differences.
#include "core/estimator/loop_point_residual.hpp"

#include <catch2/catch.hpp>

#include "tests/core/estimator/jacobian_check.hpp"
#include "tests/core/estimator/pose_block.hpp"

namespace {

struct Setup {
  double pose_loop[7], pose_t[7], ext[7];
  Eigen::Vector3d p_c0_loop;   // m, the point in the loop keyframe's left camera
  Eigen::Vector3d b_target;    // the window frame's exact bearing of it
};

Setup setup() {
  Setup s;
  ums::test::set_pose(s.pose_loop, Eigen::Vector3d(0.4, -0.3, 1.1),
                      Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 0.1, 1.0).normalized())));
  ums::test::set_pose(s.pose_t, Eigen::Vector3d(0.9, 0.2, 1.0),
                      Eigen::Quaterniond(Eigen::AngleAxisd(-0.2, Eigen::Vector3d(0.1, -0.3, 1.0).normalized())));
  ums::test::set_pose(s.ext, Eigen::Vector3d(-0.02, 0.06, 0.01),
                      Eigen::Quaterniond(Eigen::AngleAxisd(1.57, Eigen::Vector3d(0.0, 0.0, 1.0))));
  s.p_c0_loop = Eigen::Vector3d(0.3, -0.2, 3.5);
  const Eigen::Isometry3d T_b_c = ums::test::iso(s.ext);
  const Eigen::Vector3d p_w = ums::test::iso(s.pose_loop) * (T_b_c * s.p_c0_loop);
  s.b_target = ((ums::test::iso(s.pose_t) * T_b_c).inverse() * p_w).normalized();
  return s;
}

}  // namespace

TEST_CASE("loop point residual: zero at the truth, whitened like a bearing, Jacobians match", "[estimator][relocation]") {
  Setup s = setup();
  ums::LoopPointResidual r;
  const double weight = 458.0 / 1.5;  // focal / sigma, 1/rad
  r.set(s.p_c0_loop, s.b_target, weight);
  CHECK(r.num_residuals() == 2);
  const double* params[3] = {s.pose_loop, s.pose_t, s.ext};
  double res[2];
  REQUIRE(r.evaluate(params, res, nullptr));
  CHECK(std::hypot(res[0], res[1]) < 1e-9);

  // 1 px (at 458 px focal) of error in the target: 1 / 1.5 whitened.
  const Eigen::Vector3d off = (s.b_target + s.b_target.unitOrthogonal() * (1.0 / 458.0)).normalized();
  r.set(s.p_c0_loop, off, weight);
  REQUIRE(r.evaluate(params, res, nullptr));
  CHECK(std::hypot(res[0], res[1]) == Approx(1.0 / 1.5).epsilon(0.01));

  CHECK(ums::test::max_jacobian_error(r, {{s.pose_loop, 7, true}, {s.pose_t, 7, true}, {s.ext, 7, true}}) < 1e-5);
}
