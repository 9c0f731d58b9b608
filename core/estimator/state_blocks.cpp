#include "core/estimator/state_blocks.hpp"

namespace ums {

void set_quat(double* pose, const Eigen::Quaterniond& q_in) {
  const Eigen::Quaterniond q = q_in.normalized();
  pose[state::kPoseQ] = q.x();
  pose[state::kPoseQ + 1] = q.y();
  pose[state::kPoseQ + 2] = q.z();
  pose[state::kPoseQ + 3] = q.w();
}

void pose_from_iso(const Eigen::Isometry3d& T, double* pose) {
  const Eigen::Quaterniond q(T.linear());
  state::p(pose) = T.translation();
  pose[state::kPoseQ] = q.x();
  pose[state::kPoseQ + 1] = q.y();
  pose[state::kPoseQ + 2] = q.z();
  pose[state::kPoseQ + 3] = q.w();
}

Eigen::Isometry3d iso_from_pose(const double* pose) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = quat_of(pose).normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(pose[state::kPoseP], pose[state::kPoseP + 1], pose[state::kPoseP + 2]);
  return T;
}

NavState nav_from_blocks(const double* pose, const double* sb) {
  NavState s;
  s.p_w_b = state::p(pose);
  s.q_w_b = quat_of(pose).normalized();
  s.v_w_b = state::v(sb);
  s.ba = state::ba(sb);
  s.bg = state::bg(sb);
  return s;
}

void blocks_from_nav(const NavState& s, double* pose, double* sb) {
  state::p(pose) = s.p_w_b;
  set_quat(pose, s.q_w_b);
  state::v(sb) = s.v_w_b;
  state::ba(sb) = s.ba;
  state::bg(sb) = s.bg;
}

}  // namespace ums
