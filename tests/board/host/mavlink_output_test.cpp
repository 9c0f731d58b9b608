// The MAVLink output against a recording link: what it sends for each pose, the rate limit by
// data time, the heartbeat, TIMESYNC answers, reset_counter and quality, drops when the link is
// full, and no allocation per pose.
#include "board/host/mavlink_output.hpp"

#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "core/estimator/estimator.hpp"
#include "core/imu/propagation.hpp"
#include "core/mavlink/messages.hpp"
#include "profiling/alloc_counter.hpp"

using namespace ums;
using namespace ums::cli;

namespace {

class RecordingLink final : public hal::ByteLink {
 public:
  RecordingLink() { ids.reserve(4096); }  // reserved: recording allocates nothing either
  bool send(const std::uint8_t* bytes, std::size_t n) override {
    if (full) {
      ++counters_.packets_dropped;
      return false;
    }
    ++counters_.packets_sent;
    frame_bytes += n;
    last_id = static_cast<std::uint32_t>(bytes[7] | bytes[8] << 8 | bytes[9] << 16);
    ids.push_back(last_id);
    std::memcpy(last, bytes, n);
    if (last_id == mavlink::kTimesync.id) std::memcpy(last_timesync, bytes, n);
    return true;
  }
  std::size_t receive(std::uint8_t* out, std::size_t cap) override {
    const std::size_t n = std::min(cap, incoming.size());
    if (n == 0) return 0;  // incoming.data() may be null: memcpy from null is undefined even for 0 bytes (UBSan)
    std::memcpy(out, incoming.data(), n);
    incoming.erase(incoming.begin(), incoming.begin() + static_cast<long>(n));
    return n;
  }
  const hal::LinkCounters& counters() const override { return counters_; }
  const char* description() const override { return "recording"; }

  bool full = false;
  std::vector<std::uint32_t> ids;
  std::vector<std::uint8_t> incoming;
  std::size_t frame_bytes = 0;
  std::uint32_t last_id = 0;
  std::uint8_t last[mavlink::kMaxFrameBytes] = {};
  std::uint8_t last_timesync[mavlink::kMaxFrameBytes] = {};

 private:
  hal::LinkCounters counters_;
};

EstimatorOutput pose_at(double t_s, EstimatorMode mode = EstimatorMode::kVio, int landmarks = 120) {
  EstimatorOutput o;
  o.t_ns = static_cast<std::int64_t>(t_s * 1e9);
  o.valid = true;
  o.mode = mode;
  o.landmarks_in_solve = landmarks;
  o.p_w_b = Eigen::Vector3d(1.0, 2.0, 3.0);
  return o;
}

int count(const std::vector<std::uint32_t>& ids, const mavlink::MessageSpec& spec) {
  return static_cast<int>(std::count(ids.begin(), ids.end(), spec.id));
}

mavlink::PayloadReader payload_of(const RecordingLink& link) {
  return mavlink::PayloadReader(link.last + mavlink::kHeaderBytes, link.last[1]);
}

}  // namespace

TEST_CASE("MavlinkOutput: 20 Hz poses at --mavlink-rate 10 send every other one, a heartbeat each second", "[mavlink]") {
  RecordingLink link;
  MavlinkOutputOptions o;
  o.rate_hz = 10.0;
  MavlinkOutput out(o, &link);
  for (int k = 0; k < 60; ++k) out.on_frame_pose(pose_at(100.0 + 0.05 * k));  // 3 s at 20 Hz
  CHECK(out.counters().odometry_sent == 30);
  CHECK(out.counters().rate_skipped == 30);
  CHECK(count(link.ids, mavlink::kOdometry) == 30);
  CHECK(count(link.ids, mavlink::kHeartbeat) == 3);
  CHECK(link.ids.front() == mavlink::kHeartbeat.id);  // announced before the first estimate
}

TEST_CASE("MavlinkOutput: time_usec is the frame's time, reset_counter and quality the estimator's", "[mavlink]") {
  RecordingLink link;
  MavlinkOutput out(MavlinkOutputOptions{}, &link);
  EstimatorOutput p = pose_at(12.5, EstimatorMode::kVio, 120);
  p.reset_counter = 258;  // sent modulo 256
  out.on_frame_pose(p);
  REQUIRE(link.last_id == mavlink::kOdometry.id);
  mavlink::PayloadReader r = payload_of(link);
  CHECK(r.u64(0) == 12'500'000u);
  CHECK(r.u8(230) == 2);
  CHECK(static_cast<std::int8_t>(r.u8(232)) == 100);
  out.on_frame_pose(pose_at(13.0, EstimatorMode::kVo, 40));
  CHECK(static_cast<std::int8_t>(payload_of(link).u8(232)) == 35);
  out.on_frame_pose(pose_at(13.5, EstimatorMode::kImuOnly, 0));
  CHECK(static_cast<std::int8_t>(payload_of(link).u8(232)) == 1);
}

TEST_CASE("MavlinkOutput: IMU-rate output follows the IMU poses once a frame pose exists", "[mavlink]") {
  RecordingLink link;
  MavlinkOutputOptions o;
  o.imu_rate = true;
  o.rate_hz = 100.0;
  MavlinkOutput out(o, &link);
  NavState s;
  out.on_imu_pose(1'000'000'000, s);  // before any frame: no reset counter or quality yet
  CHECK(out.counters().odometry_sent == 0);
  out.on_frame_pose(pose_at(1.0));
  CHECK(out.counters().odometry_sent == 0);  // the frame's pose is not sent in IMU-rate mode
  for (int k = 1; k <= 200; ++k) out.on_imu_pose(1'000'000'000 + k * 5'000'000LL, s);  // 200 Hz for 1 s
  CHECK(out.counters().odometry_sent == 100);
}

TEST_CASE("MavlinkOutput: a TIMESYNC request is answered with the pipeline's clock and the same ts1", "[mavlink]") {
  RecordingLink link;
  MavlinkOutput out(MavlinkOutputOptions{}, &link);
  mavlink::Sender fc;
  fc.system_id = 1;
  fc.component_id = 1;
  mavlink::Timesync req;
  req.ts1 = 987654321;
  mavlink::PayloadWriter w;
  mavlink::encode(req, &w);
  std::uint8_t frame[mavlink::kMaxFrameBytes];
  const std::size_t n = mavlink::frame_message(mavlink::kTimesync, w, &fc, frame);
  link.incoming.assign(frame, frame + n);
  mavlink::Timesync not_a_request = req;
  not_a_request.tc1 = 5;  // someone's answer: not answered again
  mavlink::PayloadWriter w2;
  mavlink::encode(not_a_request, &w2);
  const std::size_t n2 = mavlink::frame_message(mavlink::kTimesync, w2, &fc, frame);
  link.incoming.insert(link.incoming.end(), frame, frame + n2);
  out.on_frame_pose(pose_at(42.0));
  REQUIRE(out.counters().timesync_answered == 1);
  REQUIRE(count(link.ids, mavlink::kTimesync) == 1);
  // The answer goes out first (the link is read before anything is sent), then heartbeat and pose.
  REQUIRE(link.ids.size() == 3);
  CHECK(link.ids[0] == mavlink::kTimesync.id);
  const mavlink::Timesync answer =
      mavlink::decode_timesync(mavlink::PayloadReader(link.last_timesync + mavlink::kHeaderBytes, link.last_timesync[1]));
  CHECK(answer.tc1 == 42'000'000'000LL);
  CHECK(answer.ts1 == 987654321);
  CHECK(answer.target_system == 1);
  CHECK(answer.target_component == 1);
}

TEST_CASE("MavlinkOutput: a full link drops and counts, and the estimate goes on", "[mavlink]") {
  RecordingLink link;
  link.full = true;
  MavlinkOutput out(MavlinkOutputOptions{}, &link);
  for (int k = 0; k < 10; ++k) out.on_frame_pose(pose_at(1.0 + 0.05 * k));
  CHECK(out.counters().odometry_dropped == 10);
  CHECK(out.counters().odometry_sent == 0);
  link.full = false;
  out.on_frame_pose(pose_at(2.0));
  CHECK(out.counters().odometry_sent == 1);
}

TEST_CASE("MavlinkOutput: VISION_POSITION_ESTIMATE and VISION_SPEED_ESTIMATE carry the same pose", "[mavlink]") {
  RecordingLink link;
  MavlinkOutputOptions o;
  o.vision_messages = true;
  MavlinkOutput out(o, &link);
  EstimatorOutput p = pose_at(3.0);
  p.v_w_b = Eigen::Vector3d(0.0, 0.0, 1.0);  // climbing: NED vz < 0
  out.on_frame_pose(p);
  CHECK(count(link.ids, mavlink::kVisionPositionEstimate) == 1);
  REQUIRE(link.last_id == mavlink::kVisionSpeedEstimate.id);
  CHECK(payload_of(link).f32(16) == Approx(-1.0f));
  CHECK(out.counters().vision_sent == 2);
}

TEST_CASE("MavlinkOutput: sending a pose allocates nothing", "[mavlink]") {
  RecordingLink link;
  MavlinkOutput out(MavlinkOutputOptions{}, &link);
  out.on_frame_pose(pose_at(1.0));
  NavState s;
  AllocScope scope;
  for (int k = 1; k < 100; ++k) {
    out.on_frame_pose(pose_at(1.0 + 0.05 * k));
    out.on_imu_pose(static_cast<std::int64_t>((1.0 + 0.05 * k) * 1e9), s);
  }
  CHECK(scope.allocations() == 0);
}

TEST_CASE("MavlinkOutputOptions: a rate out of range or a mount that is no rotation is refused", "[mavlink]") {
  MavlinkOutputOptions o;
  o.rate_hz = -1.0;
  CHECK_THROWS_WITH(o.validate(), Catch::Contains("rate_hz"));
  o = MavlinkOutputOptions{};
  o.R_b_v = Eigen::Vector3d(1.0, 1.0, -1.0).asDiagonal();  // a reflection
  CHECK_THROWS_WITH(o.validate(), Catch::Contains("not a rotation"));
}
