#include "core/mavlink/messages.hpp"

#include <limits>

namespace ums::mavlink {
namespace {

constexpr float kUnknown = std::numeric_limits<float>::quiet_NaN();

template <int N>
void unknown_covariance(float (&c)[N]) {
  for (float& x : c) x = 0.0f;
  c[0] = kUnknown;
}

template <int N>
void put_floats(PayloadWriter* w, std::size_t offset, const float (&v)[N]) {
  for (int i = 0; i < N; ++i) w->f32(offset + 4 * static_cast<std::size_t>(i), v[i]);
}

}  // namespace

Odometry::Odometry() {
  unknown_covariance(pose_covariance);
  unknown_covariance(velocity_covariance);
}

VisionPositionEstimate::VisionPositionEstimate() { unknown_covariance(covariance); }

VisionSpeedEstimate::VisionSpeedEstimate() { unknown_covariance(covariance); }

void encode(const Heartbeat& m, PayloadWriter* w) {
  w->u32(0, 0);  // custom_mode
  w->u8(4, kTypeOnboardController);
  w->u8(5, kAutopilotInvalid);
  w->u8(6, 0);   // base_mode
  w->u8(7, m.system_status);
  w->u8(8, 3);   // mavlink_version
}

void encode(const Odometry& m, PayloadWriter* w) {
  w->u64(0, m.time_usec);
  w->f32(8, m.x);
  w->f32(12, m.y);
  w->f32(16, m.z);
  put_floats(w, 20, m.q);
  w->f32(36, m.vx);
  w->f32(40, m.vy);
  w->f32(44, m.vz);
  w->f32(48, m.rollspeed);
  w->f32(52, m.pitchspeed);
  w->f32(56, m.yawspeed);
  put_floats(w, 60, m.pose_covariance);
  put_floats(w, 144, m.velocity_covariance);
  w->u8(228, m.frame_id);
  w->u8(229, m.child_frame_id);
  w->u8(230, m.reset_counter);
  w->u8(231, m.estimator_type);
  w->i8(232, m.quality);
}

void encode(const VisionPositionEstimate& m, PayloadWriter* w) {
  w->u64(0, m.usec);
  w->f32(8, m.x);
  w->f32(12, m.y);
  w->f32(16, m.z);
  w->f32(20, m.roll);
  w->f32(24, m.pitch);
  w->f32(28, m.yaw);
  put_floats(w, 32, m.covariance);
  w->u8(116, m.reset_counter);
}

void encode(const VisionSpeedEstimate& m, PayloadWriter* w) {
  w->u64(0, m.usec);
  w->f32(8, m.x);
  w->f32(12, m.y);
  w->f32(16, m.z);
  put_floats(w, 20, m.covariance);
  w->u8(56, m.reset_counter);
}

void encode(const Timesync& m, PayloadWriter* w) {
  w->i64(0, m.tc1);
  w->i64(8, m.ts1);
  w->u8(16, m.target_system);
  w->u8(17, m.target_component);
}

Timesync decode_timesync(const PayloadReader& r) {
  Timesync m;
  m.tc1 = r.i64(0);
  m.ts1 = r.i64(8);
  m.target_system = r.u8(16);
  m.target_component = r.u8(17);
  return m;
}

}  // namespace ums::mavlink
