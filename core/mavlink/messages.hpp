#pragma once
// The MAVLink messages the product sends (and TIMESYNC, which it also answers), with their
// wire layout from the common/minimal message definitions: fields sorted by size (8, 4, 2, 1
// bytes), extension fields after them in definition order. CRC_EXTRA values are the ones the
// reference C library uses; tests/core/mavlink recomputes them from the field lists.

#include <cstdint>

#include "core/mavlink/frame_v2.hpp"

namespace ums::mavlink {

constexpr MessageSpec kHeartbeat{0, 50, 9, 9};
constexpr MessageSpec kVisionPositionEstimate{102, 158, 32, 117};
constexpr MessageSpec kVisionSpeedEstimate{103, 208, 20, 57};
constexpr MessageSpec kTimesync{111, 34, 16, 18};
constexpr MessageSpec kOdometry{331, 91, 230, 233};

// MAV_FRAME, MAV_ESTIMATOR_TYPE, MAV_TYPE, MAV_AUTOPILOT, MAV_STATE values used here.
constexpr std::uint8_t kFrameLocalNed = 1;
constexpr std::uint8_t kFrameBodyFrd = 12;
constexpr std::uint8_t kFrameLocalFrd = 20;
constexpr std::uint8_t kEstimatorTypeVio = 3;
constexpr std::uint8_t kTypeOnboardController = 18;
constexpr std::uint8_t kAutopilotInvalid = 8;
constexpr std::uint8_t kStateActive = 4;
constexpr std::uint8_t kStateCritical = 5;

struct Heartbeat {
  std::uint8_t system_status = kStateActive;
};

// ODOMETRY #331. Covariances: upper triangle, row-major, of (x, y, z, roll, pitch, yaw) and
// (vx, vy, vz, rollspeed, pitchspeed, yawspeed); element 0 NaN means unknown.
struct Odometry {
  std::uint64_t time_usec = 0;
  float x = 0, y = 0, z = 0;            // m, in frame_id
  float q[4] = {1, 0, 0, 0};            // w, x, y, z: child (body) to frame_id
  float vx = 0, vy = 0, vz = 0;         // m/s, in child_frame_id
  float rollspeed = 0, pitchspeed = 0, yawspeed = 0;  // rad/s, in child_frame_id
  float pose_covariance[21];
  float velocity_covariance[21];
  std::uint8_t frame_id = kFrameLocalFrd;
  std::uint8_t child_frame_id = kFrameBodyFrd;
  std::uint8_t reset_counter = 0;
  std::uint8_t estimator_type = kEstimatorTypeVio;
  std::int8_t quality = 0;              // %: -1 failed, 0 unknown, 1 worst .. 100 best
  Odometry();                           // covariances unknown (NaN)
};

// VISION_POSITION_ESTIMATE #102 (for stacks without ODOMETRY support).
struct VisionPositionEstimate {
  std::uint64_t usec = 0;
  float x = 0, y = 0, z = 0, roll = 0, pitch = 0, yaw = 0;  // m, rad (NED/FRD)
  float covariance[21];
  std::uint8_t reset_counter = 0;
  VisionPositionEstimate();
};

// VISION_SPEED_ESTIMATE #103.
struct VisionSpeedEstimate {
  std::uint64_t usec = 0;
  float x = 0, y = 0, z = 0;  // m/s (NED/FRD)
  float covariance[9];
  std::uint8_t reset_counter = 0;
  VisionSpeedEstimate();
};

// TIMESYNC #111: a request has tc1 = 0; the answer puts the answerer's time in tc1, mirrors ts1.
struct Timesync {
  std::int64_t tc1 = 0;  // ns
  std::int64_t ts1 = 0;  // ns
  std::uint8_t target_system = 0;
  std::uint8_t target_component = 0;
};

void encode(const Heartbeat& m, PayloadWriter* w);
void encode(const Odometry& m, PayloadWriter* w);
void encode(const VisionPositionEstimate& m, PayloadWriter* w);
void encode(const VisionSpeedEstimate& m, PayloadWriter* w);
void encode(const Timesync& m, PayloadWriter* w);
Timesync decode_timesync(const PayloadReader& r);

}  // namespace ums::mavlink
