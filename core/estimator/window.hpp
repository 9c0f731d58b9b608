#pragma once
// The sliding window's frames. Each frame lives in a fixed slot (its state blocks are bound to
// the solver and the pose cache by address, so a slot never moves); the window's order is a list
// of slots, oldest first, and every frame carries a FrameId that is never reused, so the prior,
// the keyframe outlet and the loop-closure database can name a frame after its slot is recycled.
// One more slot than the window holds: the next frame's, whose IMU interval is already open.

#include <cstdint>
#include <memory>

#include <Eigen/Geometry>

#include "core/common/capacity.hpp"
#include "core/common/state_layout.hpp"
#include "core/estimator/extrinsics.hpp"
#include "core/estimator/gyro_scale.hpp"
#include "core/estimator/time_offset.hpp"
#include "core/estimator/frame_id.hpp"
#include "core/estimator/imu_factor.hpp"
#include "core/imu/preintegration.hpp"

namespace ums {

struct WindowFrame {
  FrameId id = kNoFrame;
  std::int64_t t_ns = 0;   // IMU clock
  double td_applied_s = 0.0;  // s, the camera-IMU offset t_ns carries (the image was taken at t - td_applied + td)
  double pose[state::kPoseSize] = {0, 0, 0, 0, 0, 0, 1};
  double sb[state::kSbSize] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  Preintegration pre;      // previous window frame -> this one
  ImuFactor imu;
  bool imu_ok = false;
  bool keyframe = false;
  bool still = false;
};

class Window {
 public:
  static constexpr int kSlots = static_cast<int>(capacity::kWindowSize) + 1;

  explicit Window(const PreintegrationOptions& preintegration);

  int size() const { return n_; }
  bool empty() const { return n_ == 0; }
  // By position, 0 = oldest.
  WindowFrame& at(int pos) { return slots_[order_[pos]]; }
  const WindowFrame& at(int pos) const { return slots_[order_[pos]]; }
  WindowFrame& newest() { return at(n_ - 1); }
  int slot_at(int pos) const { return order_[pos]; }
  // By slot.
  WindowFrame& slot(int s) { return slots_[s]; }
  const WindowFrame& slot(int s) const { return slots_[s]; }
  int slot_of(const WindowFrame& f) const { return static_cast<int>(&f - slots_.get()); }
  int position_of(int slot) const;     // -1: not in the window
  int slot_of_id(FrameId id) const;    // -1: not in the window
  Eigen::Isometry3d T_w_b(int slot) const;

  // The slot the next frame takes (its IMU interval is the open one).
  WindowFrame& next() { return slots_[next_slot_]; }
  int next_slot() const { return next_slot_; }
  // Appends the next slot as the newest frame with a new FrameId.
  WindowFrame& push_next();
  // Takes the frame at `pos` out of the order (landmarks are the caller's business).
  void erase(int pos);
  // After the slide: the first slot not in the window becomes the next one.
  void choose_next_slot();

  // Rotates the window's poses and velocities about `pivot` (the initialization levels the VO
  // frame to gravity; loop closure moves T_w_odom instead, never the window).
  void rotate(const Eigen::Matrix3d& R, const Eigen::Vector3d& pivot) { move(R, pivot, pivot); }
  // Moves the window rigidly: p -> to + R (p - from), attitudes and velocities turned by R.
  void move(const Eigen::Matrix3d& R, const Eigen::Vector3d& from, const Eigen::Vector3d& to);
  // IMU factors at the current biases (re-integrating intervals whose biases moved far).
  void update_imu_factors(const Eigen::Vector3d& g_w);

  Extrinsics& extrinsics() { return extrinsics_; }
  const Extrinsics& extrinsics() const { return extrinsics_; }
  TimeOffset& time_offset() { return time_offset_; }
  const TimeOffset& time_offset() const { return time_offset_; }
  GyroScale& gyro_scale() { return gyro_scale_; }
  const GyroScale& gyro_scale() const { return gyro_scale_; }

 private:
  std::unique_ptr<WindowFrame[]> slots_;
  int order_[kSlots] = {};
  int n_ = 0;
  int next_slot_ = 0;
  FrameId next_id_ = 0;
  Extrinsics extrinsics_;
  TimeOffset time_offset_;
  GyroScale gyro_scale_;
};

}  // namespace ums
