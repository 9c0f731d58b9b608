#include "board/host/mavlink_output.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/estimator/estimator.hpp"
#include "core/imu/propagation.hpp"

namespace ums::cli {
namespace {

const mavlink::MessageSpec kReceived[] = {mavlink::kTimesync, mavlink::kHeartbeat};

constexpr std::int64_t kHeartbeatPeriodNs = 1'000'000'000;
constexpr std::int64_t kRateJitterNs = 2'000'000;  // a frame 2 ms early still counts as due

std::int8_t quality_of(const EstimatorOutput& out) {
  const int n = out.landmarks_in_solve;
  switch (out.mode) {
    case EstimatorMode::kImuOnly: return 1;
    case EstimatorMode::kVisionLost: return 10;  // a VIO state carried by the IMU alone: drifting
    case EstimatorMode::kVo: return static_cast<std::int8_t>(25 + std::min(25, n / 4));
    case EstimatorMode::kVio: return static_cast<std::int8_t>(50 + std::min(50, n / 2));
  }
  return 0;
}

// Roll, pitch, yaw (Z-Y-X) of R_L_v, for VISION_POSITION_ESTIMATE.
Eigen::Vector3d euler_zyx(const Eigen::Quaterniond& q) {
  const Eigen::Matrix3d R = q.toRotationMatrix();
  const double pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
  return {std::atan2(R(2, 1), R(2, 2)), pitch, std::atan2(R(1, 0), R(0, 0))};
}

}  // namespace

void MavlinkOutputOptions::validate() const {
  if (!(rate_hz >= 0.0 && rate_hz <= 1000.0))
    throw std::invalid_argument("MavlinkOutputOptions.rate_hz = " + std::to_string(rate_hz) + ": allowed 0..1000 Hz");
  if (system_id == 0) throw std::invalid_argument("MavlinkOutputOptions.system_id = 0: allowed 1..255");
  const double ortho = (R_b_v.transpose() * R_b_v - Eigen::Matrix3d::Identity()).norm();
  if (!(ortho < 1e-6) || !(R_b_v.determinant() > 0.0))
    throw std::invalid_argument("MavlinkOutputOptions.R_b_v: not a rotation (body_T_vehicle)");
}

MavlinkOutput::MavlinkOutput(const MavlinkOutputOptions& options, hal::ByteLink* link)
    : options_(options),
      link_(link),
      frd_(options.R_b_v),
      parser_(kReceived, sizeof(kReceived) / sizeof(kReceived[0])),
      period_ns_(options.rate_hz > 0.0 ? static_cast<std::int64_t>(1e9 / options.rate_hz) : 0) {
  options_.validate();
  sender_.system_id = options.system_id;
}

const char* MavlinkOutput::log_header() {
  return "seq,time_usec,x,y,z,qw,qx,qy,qz,vx,vy,vz,reset_counter,quality,sent\n";
}

void MavlinkOutput::on_frame_pose(const EstimatorOutput& out) {
  have_frame_ = true;
  reset_counter_ = out.reset_counter;
  quality_ = quality_of(out);
  poll_incoming(out.t_ns);
  maybe_heartbeat(out.t_ns);
  if (options_.imu_rate) return;
  mavlink::BodyState s;
  s.t_ns = out.t_ns;
  s.p_w_b = out.p_w_b;
  s.q_w_b = out.q_w_b;
  s.v_w_b = out.v_w_b;
  send_odometry(s);
}

void MavlinkOutput::on_imu_pose(std::int64_t t_ns, const NavState& state) {
  if (!options_.imu_rate || !have_frame_) return;
  mavlink::BodyState s;
  s.t_ns = t_ns;
  s.p_w_b = state.p_w_b;
  s.q_w_b = state.q_w_b;
  s.v_w_b = state.v_w_b;
  send_odometry(s);
}

void MavlinkOutput::send_odometry(const mavlink::BodyState& s) {
  if (period_ns_ > 0 && last_odometry_ns_ >= 0 && s.t_ns - last_odometry_ns_ < period_ns_ - kRateJitterNs) {
    ++counters_.rate_skipped;
    return;
  }
  last_odometry_ns_ = s.t_ns;
  mavlink::Odometry m;
  frd_.convert(s, &m);
  m.reset_counter = static_cast<std::uint8_t>(reset_counter_ & 0xFF);
  m.quality = quality_;
  counters_.reset_counter = reset_counter_;
  mavlink::PayloadWriter payload;
  mavlink::encode(m, &payload);
  const std::uint8_t seq = sender_.sequence;
  const bool sent = send(mavlink::kOdometry, payload);
  if (sent) {
    ++counters_.odometry_sent;
  } else {
    ++counters_.odometry_dropped;
  }
  log(m, sent, seq);
  if (options_.vision_messages) send_vision(m);
}

void MavlinkOutput::send_vision(const mavlink::Odometry& m) {
  const Eigen::Quaterniond q_L_v(static_cast<double>(m.q[0]), static_cast<double>(m.q[1]),
                                 static_cast<double>(m.q[2]), static_cast<double>(m.q[3]));
  const Eigen::Vector3d rpy = euler_zyx(q_L_v);
  const Eigen::Vector3d v_L =
      q_L_v * Eigen::Vector3d(static_cast<double>(m.vx), static_cast<double>(m.vy), static_cast<double>(m.vz));
  mavlink::VisionPositionEstimate vpe;
  vpe.usec = m.time_usec;
  vpe.x = m.x;
  vpe.y = m.y;
  vpe.z = m.z;
  vpe.roll = static_cast<float>(rpy.x());
  vpe.pitch = static_cast<float>(rpy.y());
  vpe.yaw = static_cast<float>(rpy.z());
  vpe.reset_counter = m.reset_counter;
  mavlink::VisionSpeedEstimate vse;
  vse.usec = m.time_usec;
  vse.x = static_cast<float>(v_L.x());
  vse.y = static_cast<float>(v_L.y());
  vse.z = static_cast<float>(v_L.z());
  vse.reset_counter = m.reset_counter;
  mavlink::PayloadWriter a, b;
  mavlink::encode(vpe, &a);
  mavlink::encode(vse, &b);
  counters_.vision_sent += static_cast<std::uint64_t>(send(mavlink::kVisionPositionEstimate, a)) +
                           static_cast<std::uint64_t>(send(mavlink::kVisionSpeedEstimate, b));
}

void MavlinkOutput::maybe_heartbeat(std::int64_t t_ns) {
  if (last_heartbeat_ns_ >= 0 && t_ns - last_heartbeat_ns_ < kHeartbeatPeriodNs) return;
  last_heartbeat_ns_ = t_ns;
  mavlink::PayloadWriter payload;
  mavlink::encode(mavlink::Heartbeat{}, &payload);
  if (send(mavlink::kHeartbeat, payload)) ++counters_.heartbeats;
}

// TIMESYNC requests (tc1 = 0) are answered at once with the pipeline's clock.
void MavlinkOutput::poll_incoming(std::int64_t now_ns) {
  for (;;) {
    const std::size_t n = link_->receive(rx_, sizeof(rx_));
    if (n == 0) return;
    for (std::size_t i = 0; i < n; ++i) {
      if (!parser_.push(rx_[i]) || parser_.message().id != mavlink::kTimesync.id) continue;
      const mavlink::ReceivedMessage& in = parser_.message();
      mavlink::Timesync req = mavlink::decode_timesync(mavlink::PayloadReader(in.payload, in.len));
      if (req.tc1 != 0) continue;  // someone else's answer
      mavlink::Timesync answer;
      answer.tc1 = now_ns;
      answer.ts1 = req.ts1;
      answer.target_system = in.system_id;
      answer.target_component = in.component_id;
      mavlink::PayloadWriter payload;
      mavlink::encode(answer, &payload);
      if (send(mavlink::kTimesync, payload)) ++counters_.timesync_answered;
    }
  }
}

bool MavlinkOutput::send(const mavlink::MessageSpec& spec, const mavlink::PayloadWriter& payload) {
  const std::size_t n = mavlink::frame_message(spec, payload, &sender_, frame_);
  return link_->send(frame_, n);
}

void MavlinkOutput::log(const mavlink::Odometry& m, bool sent, std::uint8_t seq) {
  if (options_.log == nullptr) return;
  // %.9g prints each float exactly (it reads back to the same float).
  const float fields[] = {m.x, m.y, m.z, m.q[0], m.q[1], m.q[2], m.q[3], m.vx, m.vy, m.vz};
  std::fprintf(options_.log, "%u,%llu", static_cast<unsigned>(seq), static_cast<unsigned long long>(m.time_usec));
  for (float f : fields) std::fprintf(options_.log, ",%.9g", static_cast<double>(f));
  std::fprintf(options_.log, ",%u,%d,%d\n", static_cast<unsigned>(m.reset_counter), static_cast<int>(m.quality),
               sent ? 1 : 0);
}

void MavlinkOutput::write_stats(JsonWriter& w) const {
  const hal::LinkCounters& l = link_->counters();
  w.begin_object("mavlink")
      .value("link", link_->description())
      .value("odometry_sent", counters_.odometry_sent)
      .value("odometry_dropped", counters_.odometry_dropped)
      .value("rate_skipped", counters_.rate_skipped)
      .value("heartbeats", counters_.heartbeats)
      .value("vision_sent", counters_.vision_sent)
      .value("timesync_answered", counters_.timesync_answered)
      .value("reset_counter", static_cast<std::uint64_t>(counters_.reset_counter))
      .value("link_packets_sent", l.packets_sent)
      .value("link_packets_dropped", l.packets_dropped)
      .value("link_bytes_sent", l.bytes_sent)
      .value("link_bytes_received", l.bytes_received)
      .value("link_errors", l.errors)
      .end_object();
}

}  // namespace ums::cli
