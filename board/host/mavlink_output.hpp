#pragma once
// The estimate to a flight controller over MAVLink v2 (docs/mavlink.md): ODOMETRY #331 in
// LOCAL_FRD / BODY_FRD (core/mavlink/frd_odometry.hpp), at the camera rate or the IMU rate, rate
// limited by data time; a HEARTBEAT each second of data; optionally VISION_POSITION_ESTIMATE and
// VISION_SPEED_ESTIMATE for stacks that take no ODOMETRY; TIMESYNC requests answered in the
// clock of time_usec (the pipeline's: the IMU clock). time_usec is the measurement's time, not
// the time of sending. reset_counter is the estimator's (EstimatorOutput::reset_counter) modulo
// 256. Covariances are sent as unknown (NaN): the estimator does not compute them yet.
//
// quality: IMU_ONLY 1 (dead reckoning), VO 25..50 and VIO 50..100 rising with the landmarks in
// the frame's solve (full at 100, the VIO count at which the window is well constrained).
//
// Everything is sent from the pipeline's thread inside the pose callbacks; the link never blocks
// (hal/link), so a slow or absent receiver costs the estimator only the send calls.

#include <cstdint>
#include <cstdio>

#include <Eigen/Core>

#include "core/mavlink/frame_parser.hpp"
#include "core/mavlink/frd_odometry.hpp"
#include "core/pipeline/pose_sink.hpp"
#include "hal/link/byte_link.hpp"
#include "profiling/json_writer.hpp"

namespace ums::cli {

struct MavlinkOutputOptions {
  double rate_hz = 30.0;          // Hz, most ODOMETRY messages per second of data (0: every pose)
  bool imu_rate = false;          // the IMU-rate pose rather than the frame's (then rates up to rate_hz)
  bool vision_messages = false;   // also VISION_POSITION_ESTIMATE + VISION_SPEED_ESTIMATE
  std::uint8_t system_id = 1;     // the vehicle's system id (the flight controller's)
  Eigen::Matrix3d R_b_v = Eigen::Matrix3d::Identity();  // vehicle FRD axes in the body: v_b = R_b_v v_v
  std::FILE* log = nullptr;       // one CSV line per ODOMETRY (log_header()); not owned
  void validate() const;          // std::invalid_argument naming the field
};

struct MavlinkCounters {
  std::uint64_t odometry_sent = 0;
  std::uint64_t odometry_dropped = 0;   // the link was full or down
  std::uint64_t rate_skipped = 0;       // poses not sent: within the rate limit's period
  std::uint64_t heartbeats = 0;
  std::uint64_t vision_sent = 0;        // VPE + VSE messages accepted by the link
  std::uint64_t timesync_answered = 0;
  std::uint32_t reset_counter = 0;      // the last one sent (before the modulo)
};

class MavlinkOutput final : public PoseSink {
 public:
  MavlinkOutput(const MavlinkOutputOptions& options, hal::ByteLink* link);  // link not owned

  void on_frame_pose(const EstimatorOutput& out) override;
  void on_imu_pose(std::int64_t t_ns, const NavState& state) override;

  const MavlinkCounters& counters() const { return counters_; }
  static const char* log_header();
  // stats.json "mavlink": the link, the counters and the link's own.
  void write_stats(JsonWriter& w) const;

 private:
  void poll_incoming(std::int64_t now_ns);
  void maybe_heartbeat(std::int64_t t_ns);
  void send_odometry(const mavlink::BodyState& s);
  void send_vision(const mavlink::Odometry& m);
  bool send(const mavlink::MessageSpec& spec, const mavlink::PayloadWriter& payload);
  void log(const mavlink::Odometry& m, bool sent, std::uint8_t seq);

  MavlinkOutputOptions options_;
  hal::ByteLink* link_;
  mavlink::Sender sender_;
  mavlink::FrdConverter frd_;
  mavlink::FrameParser parser_;
  std::int64_t period_ns_;
  std::int64_t last_odometry_ns_ = -1;
  std::int64_t last_heartbeat_ns_ = -1;
  bool have_frame_ = false;
  std::uint32_t reset_counter_ = 0;
  std::int8_t quality_ = 0;
  MavlinkCounters counters_;
  std::uint8_t frame_[mavlink::kMaxFrameBytes] = {};
  std::uint8_t rx_[512] = {};
};

}  // namespace ums::cli
