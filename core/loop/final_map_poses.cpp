#include "core/loop/final_map_poses.hpp"

#include <algorithm>

#include "core/math/quaternion.hpp"

namespace ums::loop {

FinalMapPoses::FinalMapPoses(const KeyframeDatabase& db) {
  keyframes_.reserve(db.size());
  for (std::int32_t s = db.oldest(); s >= 0; s = db.at(s).next) {
    const KeyframeRecord& r = db.at(s);
    if (!r.placed || r.odometry_epoch == kMapEpoch) continue;
    const double yaw_rad = quat::yaw(r.T_map_b.linear() * r.T_odom_b.linear().transpose());
    const Eigen::Vector3d p_m =
        r.T_map_b.translation() - Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()) * r.T_odom_b.translation();
    keyframes_.push_back(Keyframe{r.t_ns, r.odometry_epoch, yaw_rad, p_m});
  }
}

bool FinalMapPoses::map_pose(std::int64_t t_ns, std::uint32_t odometry_epoch, const Eigen::Isometry3d& T_odom_b,
                             Eigen::Isometry3d* T_map_b) const {
  // Epochs follow each other in time, so a frame's own keyframes are the ones just around it.
  const auto after = std::upper_bound(keyframes_.begin(), keyframes_.end(), t_ns,
                                      [](std::int64_t t, const Keyframe& k) { return t < k.t_ns; });
  const Keyframe* next = after != keyframes_.end() && after->epoch == odometry_epoch ? &*after : nullptr;
  const Keyframe* prev = after != keyframes_.begin() && (after - 1)->epoch == odometry_epoch ? &*(after - 1) : nullptr;
  if (prev == nullptr && next == nullptr) return false;
  double yaw_rad = 0.0;
  Eigen::Vector3d p_m;
  if (prev != nullptr && next != nullptr) {
    const double a = static_cast<double>(t_ns - prev->t_ns) / static_cast<double>(next->t_ns - prev->t_ns);
    yaw_rad = prev->yaw_rad + a * quat::wrap_angle_rad(next->yaw_rad - prev->yaw_rad);
    p_m = prev->p_m + a * (next->p_m - prev->p_m);
  } else {
    const Keyframe& k = prev != nullptr ? *prev : *next;
    yaw_rad = k.yaw_rad;
    p_m = k.p_m;
  }
  const Eigen::Matrix3d R = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_map_b->setIdentity();
  T_map_b->linear() = R * T_odom_b.linear();
  T_map_b->translation() = R * T_odom_b.translation() + p_m;
  return true;
}

}  // namespace ums::loop
