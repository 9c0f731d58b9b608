#pragma once
// Conversions between the window's raw state blocks (core/common/state_layout.hpp) and the
// types the rest of the estimator reasons in (Isometry3d, NavState). Quaternions read from a
// block are normalized; quaternions written by set_quat are normalized first.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/state_layout.hpp"
#include "core/imu/propagation.hpp"

namespace ums {

// The stored quaternion as it is (not normalized).
inline Eigen::Quaterniond quat_of(const double* pose) {
  return Eigen::Quaterniond(pose[state::kPoseQ + 3], pose[state::kPoseQ], pose[state::kPoseQ + 1],
                            pose[state::kPoseQ + 2]);
}
void set_quat(double* pose, const Eigen::Quaterniond& q);
// Rotation written as its quaternion without normalizing (the rotation matrix is orthonormal).
void pose_from_iso(const Eigen::Isometry3d& T, double* pose);
Eigen::Isometry3d iso_from_pose(const double* pose);
// Minimal rotation taking direction a onto b (levelling to gravity).
inline Eigen::Matrix3d rotation_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return Eigen::Quaterniond::FromTwoVectors(a, b).toRotationMatrix();
}
NavState nav_from_blocks(const double* pose, const double* sb);
void blocks_from_nav(const NavState& s, double* pose, double* sb);

}  // namespace ums
