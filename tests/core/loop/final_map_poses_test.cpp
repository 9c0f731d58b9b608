// The final map trajectory: every frame placed through the corrections (yaw and translation) of
// the keyframes of its odometry frame around it, interpolated in time; roll and pitch of the
// odometry kept; a frame whose odometry frame has no placed keyframe gets no map pose; keyframes
// read from a map file and unplaced ones give nothing.
#include "core/loop/final_map_poses.hpp"

#include <catch2/catch.hpp>

#include <cmath>

#include "core/math/quaternion.hpp"

using namespace ums;
using namespace ums::loop;

namespace {

constexpr double kDeg = M_PI / 180.0;

Eigen::Isometry3d pose(const Eigen::Vector3d& p_m, double yaw_deg, double roll_deg = 0.0) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw_deg * kDeg, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(roll_deg * kDeg, Eigen::Vector3d::UnitX())).toRotationMatrix();
  T.translation() = p_m;
  return T;
}

// A keyframe at t_s whose map pose is its odometry pose moved by (yaw_deg about z, then p_m).
void add(KeyframeDatabase* db, double t_s, std::uint32_t epoch, const Eigen::Isometry3d& T_odom_b, double yaw_deg,
         const Eigen::Vector3d& p_m, bool placed = true) {
  std::uint32_t slot = 0;
  REQUIRE(db->reserve(&slot) == Status::kOk);
  KeyframeRecord& r = db->at(slot);
  r.id = static_cast<FrameId>(db->size() + 1);
  r.t_ns = static_cast<std::int64_t>(t_s * 1e9);
  r.odometry_epoch = epoch;
  r.placed = placed;
  r.T_odom_b = T_odom_b;
  r.T_map_b = pose(p_m, yaw_deg) * T_odom_b;
  db->commit(slot);
}

std::int64_t ns(double t_s) { return static_cast<std::int64_t>(t_s * 1e9); }

}  // namespace

TEST_CASE("FinalMapPoses: a frame between two keyframes takes their corrections interpolated in time", "[loop]") {
  KeyframeDatabase db(4);
  add(&db, 1.0, 0, pose({1, 0, 1}, 0.0), 0.0, {0, 0, 0});
  add(&db, 2.0, 0, pose({2, 0, 1}, 30.0), 10.0, {1.0, -0.4, 0.2});
  const FinalMapPoses final_map(db);
  CHECK(final_map.keyframes() == 2);
  // A quarter of the way: correction yaw 2.5 deg, translation (0.25, -0.1, 0.05) m.
  const Eigen::Isometry3d T_odom_b = pose({1.3, 0.2, 1.1}, 12.0, 4.0);
  Eigen::Isometry3d T_map_b;
  REQUIRE(final_map.map_pose(ns(1.25), 0, T_odom_b, &T_map_b));
  const Eigen::Isometry3d expected = pose({0.25, -0.1, 0.05}, 2.5) * T_odom_b;
  CHECK((T_map_b.translation() - expected.translation()).norm() < 1e-9);
  CHECK(Eigen::AngleAxisd(T_map_b.linear().transpose() * expected.linear()).angle() < 1e-9);
  // At a keyframe's time its own map pose comes back.
  REQUIRE(final_map.map_pose(ns(2.0), 0, pose({2, 0, 1}, 30.0), &T_map_b));
  CHECK((T_map_b.translation() - db.at(static_cast<std::uint32_t>(db.newest())).T_map_b.translation()).norm() < 1e-9);
}

TEST_CASE("FinalMapPoses: before the first and after the last keyframe the nearest correction holds", "[loop]") {
  KeyframeDatabase db(4);
  add(&db, 1.0, 0, pose({0, 0, 0}, 0.0), 5.0, {0.3, 0, 0});
  add(&db, 2.0, 0, pose({1, 0, 0}, 0.0), -5.0, {-0.3, 0, 0});
  const FinalMapPoses final_map(db);
  Eigen::Isometry3d T_map_b;
  REQUIRE(final_map.map_pose(ns(0.5), 0, Eigen::Isometry3d::Identity(), &T_map_b));
  CHECK(std::abs(quat::yaw(T_map_b.linear()) - 5.0 * kDeg) < 1e-12);
  CHECK(std::abs(T_map_b.translation().x() - 0.3) < 1e-12);
  REQUIRE(final_map.map_pose(ns(9.0), 0, Eigen::Isometry3d::Identity(), &T_map_b));
  CHECK(std::abs(quat::yaw(T_map_b.linear()) + 5.0 * kDeg) < 1e-12);
  CHECK(std::abs(T_map_b.translation().x() + 0.3) < 1e-12);
}

TEST_CASE("FinalMapPoses: the yaw correction interpolates across +-180 deg the short way", "[loop]") {
  KeyframeDatabase db(4);
  add(&db, 1.0, 0, pose({0, 0, 0}, 0.0), 179.0, {0, 0, 0});
  add(&db, 2.0, 0, pose({0, 0, 0}, 0.0), -179.0, {0, 0, 0});
  const FinalMapPoses final_map(db);
  Eigen::Isometry3d T_map_b;
  REQUIRE(final_map.map_pose(ns(1.5), 0, Eigen::Isometry3d::Identity(), &T_map_b));
  CHECK(std::abs(std::abs(quat::yaw(T_map_b.linear())) - M_PI) < 1e-9);
}

TEST_CASE("FinalMapPoses: the odometry's roll and pitch are kept, the correction is a yaw and a translation", "[loop]") {
  KeyframeDatabase db(4);
  // A map pose tilted 0.5 deg against the odometry (a loop's roll error): not passed on.
  std::uint32_t slot = 0;
  REQUIRE(db.reserve(&slot) == Status::kOk);
  KeyframeRecord& r = db.at(slot);
  r.t_ns = ns(1.0);
  r.odometry_epoch = 0;
  r.placed = true;
  r.T_odom_b = pose({0, 0, 0}, 20.0);
  r.T_map_b = pose({0, 0, 0}, 30.0, 0.5);
  db.commit(slot);
  const FinalMapPoses final_map(db);
  const Eigen::Isometry3d T_odom_b = pose({0, 0, 0}, 40.0, 3.0);
  Eigen::Isometry3d T_map_b;
  REQUIRE(final_map.map_pose(ns(1.0), 0, T_odom_b, &T_map_b));
  const Eigen::Vector3d g_b = T_map_b.linear().transpose() * Eigen::Vector3d::UnitZ();
  CHECK((g_b - T_odom_b.linear().transpose() * Eigen::Vector3d::UnitZ()).norm() < 1e-12);
  CHECK(std::abs(quat::yaw(T_map_b.linear()) - quat::yaw(T_odom_b.linear()) - 10.0 * kDeg) < 1e-3);
}

TEST_CASE("FinalMapPoses: only this run's placed keyframes of the frame's own odometry frame place it", "[loop]") {
  KeyframeDatabase db(8);
  const Eigen::Vector3d far(100, 0, 0);
  add(&db, 0.5, kMapEpoch, pose({0, 0, 0}, 0.0), 0.0, far);          // read from a map file
  add(&db, 1.0, 0, pose({0, 0, 0}, 0.0), 0.0, {0.1, 0, 0});
  add(&db, 2.0, 0, pose({0, 0, 0}, 0.0), 0.0, {0.1, 0, 0});
  add(&db, 3.0, 1, pose({0, 0, 0}, 0.0), 0.0, far, /*placed=*/false);  // a reset, never relocalized
  add(&db, 4.0, 2, pose({0, 0, 0}, 0.0), 0.0, {-0.2, 0, 0});          // another reset, relocalized
  const FinalMapPoses final_map(db);
  CHECK(final_map.keyframes() == 3);
  Eigen::Isometry3d T_map_b;
  // After epoch 0's last keyframe, before epoch 2's first: each frame its own epoch's correction.
  REQUIRE(final_map.map_pose(ns(2.5), 0, Eigen::Isometry3d::Identity(), &T_map_b));
  CHECK(std::abs(T_map_b.translation().x() - 0.1) < 1e-12);
  CHECK_FALSE(final_map.map_pose(ns(3.0), 1, Eigen::Isometry3d::Identity(), &T_map_b));
  REQUIRE(final_map.map_pose(ns(3.5), 2, Eigen::Isometry3d::Identity(), &T_map_b));
  CHECK(std::abs(T_map_b.translation().x() + 0.2) < 1e-12);
  CHECK_FALSE(final_map.map_pose(ns(4.5), 3, Eigen::Isometry3d::Identity(), &T_map_b));
}
