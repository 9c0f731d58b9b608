#include "core/estimator/relative_pose_cache.hpp"

#include <catch2/catch.hpp>

#include <memory>

#include <Eigen/Geometry>

#include "tests/core/estimator/pose_block.hpp"

namespace {

using ums::test::iso;
using ums::test::set_pose;

// T_ct_ch composed directly: target camera <- target body <- world <- host body <- host camera.
Eigen::Isometry3d direct(const double* pose_h, const double* pose_t, const double* ext_h, const double* ext_t) {
  return iso(ext_t).inverse() * iso(pose_t).inverse() * iso(pose_h) * iso(ext_h);
}

}  // namespace

TEST_CASE("relative pose cache: camera-to-camera products equal the composed transforms, refreshed per pass",
          "[estimator]") {
  double frames[3][7], ext[2][7];
  set_pose(frames[0], {0.1, -0.2, 1.0}, Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())));
  set_pose(frames[1], {0.4, 0.1, 1.1}, Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d(-1, 2, 1).normalized())));
  set_pose(frames[2], {2.0, 1.0, 0.5}, Eigen::Quaterniond(Eigen::AngleAxisd(1.1, Eigen::Vector3d(0, 0, 1))));
  set_pose(ext[0], {0.02, -0.06, 0.01}, Eigen::Quaterniond(Eigen::AngleAxisd(1.5, Eigen::Vector3d(0.1, 0.2, 1).normalized())));
  set_pose(ext[1], {0.03, 0.05, 0.0}, Eigen::Quaterniond(Eigen::AngleAxisd(1.52, Eigen::Vector3d(0.1, 0.2, 1).normalized())));
  auto cache = std::make_unique<ums::RelativePoseCache>();
  for (int s = 0; s < 3; ++s) cache->bind_frame(s, frames[s]);
  for (int c = 0; c < 2; ++c) cache->bind_extrinsic(c, ext[c]);

  auto check_pair = [&](int h, int ch, int t, int ct) {
    const ums::RelativePoseCache::Pair& p = cache->pair(h, ch, t, ct);
    const Eigen::Isometry3d T = direct(frames[h], frames[t], ext[ch], ext[ct]);
    CHECK((p.R_ct_ch - T.linear()).cwiseAbs().maxCoeff() < 1e-12);
    CHECK((p.p_ct_ch - T.translation()).norm() < 1e-12);  // m
    const Eigen::Matrix3d R_ct_w = (iso(ext[ct]).inverse() * iso(frames[t]).inverse()).linear();
    CHECK((p.R_ct_w - R_ct_w).cwiseAbs().maxCoeff() < 1e-12);
    CHECK((p.R_ct_bh - R_ct_w * iso(frames[h]).linear()).cwiseAbs().maxCoeff() < 1e-12);
  };
  for (int h = 0; h < 3; ++h)
    for (int t = 0; t < 3; ++t)
      for (int ch = 0; ch < 2; ++ch)
        for (int ct = 0; ct < 2; ++ct) check_pair(h, ch, t, ct);

  SECTION("products hold until the next pass, then follow the moved blocks") {
    const Eigen::Vector3d before = cache->pair(0, 0, 1, 1).p_ct_ch;
    frames[1][2] += 0.25;  // m: the solver writes a trial value in place
    CHECK((cache->pair(0, 0, 1, 1).p_ct_ch - before).norm() == 0.0);  // same pass: reused
    cache->prepare_for_evaluation();                                  // the solver's next pass
    CHECK((cache->pair(0, 0, 1, 1).p_ct_ch - before).norm() > 0.2);
    check_pair(0, 0, 1, 1);
    Eigen::Map<Eigen::Quaterniond> q(frames[0] + 3);
    q = q * Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()));
    ext[1][0] += 0.01;  // the extrinsic too
    cache->invalidate();
    check_pair(0, 0, 1, 1);
    check_pair(2, 1, 1, 0);
  }
  SECTION("re-binding a slot to other memory never reuses the old products") {
    check_pair(0, 0, 1, 0);
    double other[7];
    set_pose(other, {-1.0, 0.5, 2.0}, Eigen::Quaterniond(Eigen::AngleAxisd(-0.7, Eigen::Vector3d(1, 0, 1).normalized())));
    cache->bind_frame(1, other);
    const ums::RelativePoseCache::Pair& p = cache->pair(0, 0, 1, 0);
    const Eigen::Isometry3d T = direct(frames[0], other, ext[0], ext[0]);
    CHECK((p.p_ct_ch - T.translation()).norm() < 1e-12);
  }
}
