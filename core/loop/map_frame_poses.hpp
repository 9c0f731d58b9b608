#pragma once
// Poses in the map frame for a live consumer (the MAVLink output): every frame and IMU-rate pose
// passed on as T_map_odom * T_odom_b while the odometry frame is placed in the map, and as the
// odometry while it is not (before the first levelled keyframe, or a new session not yet
// relocalized). reset_counter grows by the closer's corrections, so a consumer resets its
// reference at every map correction and at every switch between the two (issue 17 item 6).
// For a consumer that cannot take a step, spread_s > 0 moves from the old T_map_odom to a
// corrected one linearly (slerp for the rotation) over spread_s seconds of data time instead,
// and then the counter does not step for that correction (a switch of session still does).
// The IMU-rate poses take the epoch of the last frame pose. Allocates nothing.

#include <algorithm>
#include <cstdint>

#include <Eigen/Geometry>

#include "core/estimator/estimator.hpp"
#include "core/imu/propagation.hpp"
#include "core/loop/map_frame_source.hpp"
#include "core/pipeline/pose_sink.hpp"

namespace ums::loop {

class MapFramePoses final : public PoseSink {
 public:
  MapFramePoses(const MapFrameSource& closer, PoseSink* next, double spread_s = 0.0)
      : closer_(closer), next_(next), spread_ns_(static_cast<std::int64_t>(spread_s * 1e9)) {}

  void on_frame_pose(const EstimatorOutput& out) override {
    epoch_ = out.odometry_epoch;
    EstimatorOutput m = out;
    Eigen::Isometry3d T;
    const bool placed = map_from_odometry(out.t_ns, &T);
    if (placed) {
      m.p_w_b = T * out.p_w_b;
      m.q_w_b = Eigen::Quaterniond(T.linear() * out.q_w_b.toRotationMatrix()).normalized();
      m.v_w_b = T.linear() * out.v_w_b;
    }
    m.reset_counter = out.reset_counter + closer_.corrections() - smoothed_;
    next_->on_frame_pose(m);
  }

  void on_imu_pose(std::int64_t t_ns, const NavState& state) override {
    NavState m = state;
    Eigen::Isometry3d T;
    if (map_from_odometry(t_ns, &T)) {
      m.p_w_b = T * state.p_w_b;
      m.q_w_b = Eigen::Quaterniond(T.linear() * state.q_w_b.toRotationMatrix()).normalized();
      m.v_w_b = T.linear() * state.v_w_b;
    }
    next_->on_imu_pose(t_ns, m);
  }

 private:
  // The closer's T_map_odom, or with spreading the blend towards it; counts the corrections
  // that were spread instead of stepped.
  bool map_from_odometry(std::int64_t t_ns, Eigen::Isometry3d* T) {
    if (!closer_.map_from_odometry(epoch_, T)) {
      have_shown_ = false;
      return false;
    }
    if (spread_ns_ <= 0) return true;
    if (!have_shown_ || epoch_ != shown_epoch_) {
      target_ = *T;  // a new placement: no blend across frames
      start_ns_ = -1;
      have_shown_ = true;
      shown_epoch_ = epoch_;
      seen_corrections_ = closer_.corrections();
      return true;
    }
    if (closer_.corrections() != seen_corrections_) {
      from_ = blended(t_ns);
      target_ = *T;
      start_ns_ = t_ns;
      smoothed_ += closer_.corrections() - seen_corrections_;
      seen_corrections_ = closer_.corrections();
    }
    *T = blended(t_ns);
    return true;
  }

  Eigen::Isometry3d blended(std::int64_t t_ns) const {
    const double a = start_ns_ < 0 ? 1.0
                                   : std::clamp(static_cast<double>(t_ns - start_ns_) / static_cast<double>(spread_ns_), 0.0, 1.0);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    const Eigen::Quaterniond q0(from_.linear()), q1(target_.linear());
    T.linear() = q0.slerp(a, q1).toRotationMatrix();
    T.translation() = (1.0 - a) * from_.translation() + a * target_.translation();
    return T;
  }

  const MapFrameSource& closer_;
  PoseSink* next_;
  std::int64_t spread_ns_;
  std::uint32_t epoch_ = 0;
  bool have_shown_ = false;
  std::uint32_t shown_epoch_ = 0;
  Eigen::Isometry3d from_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d target_ = Eigen::Isometry3d::Identity();
  std::int64_t start_ns_ = -1;
  std::uint32_t seen_corrections_ = 0;
  std::uint32_t smoothed_ = 0;  // corrections spread, not stepped (taken out of reset_counter)
};

}  // namespace ums::loop
