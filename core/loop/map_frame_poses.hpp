#pragma once
// Poses in the map frame for a live consumer (the MAVLink output): every frame and IMU-rate pose
// passed on as T_map_odom * T_odom_b while the odometry frame is placed in the map, and as the
// odometry while it is not (before the first levelled keyframe, or a new session not yet
// relocalized). reset_counter grows by the closer's corrections, so a consumer resets its
// reference at every map correction and at every switch between the two (issue 17 item 6).
// The IMU-rate poses take the epoch of the last frame pose. Allocates nothing.

#include <cstdint>

#include <Eigen/Geometry>

#include "core/estimator/estimator.hpp"
#include "core/imu/propagation.hpp"
#include "core/loop/loop_closer.hpp"
#include "core/pipeline/pose_sink.hpp"

namespace ums::loop {

class MapFramePoses final : public PoseSink {
 public:
  MapFramePoses(const LoopCloser& closer, PoseSink* next) : closer_(closer), next_(next) {}

  void on_frame_pose(const EstimatorOutput& out) override {
    epoch_ = out.odometry_epoch;
    EstimatorOutput m = out;
    Eigen::Isometry3d T;
    if (closer_.map_from_odometry(out.odometry_epoch, &T)) {
      m.p_w_b = T * out.p_w_b;
      m.q_w_b = Eigen::Quaterniond(T.linear() * out.q_w_b.toRotationMatrix()).normalized();
      m.v_w_b = T.linear() * out.v_w_b;
    }
    m.reset_counter = out.reset_counter + closer_.corrections();
    next_->on_frame_pose(m);
  }

  void on_imu_pose(std::int64_t t_ns, const NavState& state) override {
    NavState m = state;
    Eigen::Isometry3d T;
    if (closer_.map_from_odometry(epoch_, &T)) {
      m.p_w_b = T * state.p_w_b;
      m.q_w_b = Eigen::Quaterniond(T.linear() * state.q_w_b.toRotationMatrix()).normalized();
      m.v_w_b = T.linear() * state.v_w_b;
    }
    next_->on_imu_pose(t_ns, m);
  }

 private:
  const LoopCloser& closer_;
  PoseSink* next_;
  std::uint32_t epoch_ = 0;
};

}  // namespace ums::loop
