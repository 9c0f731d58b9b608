// The message tables: CRC_EXTRA recomputed from the field lists of the message definitions
// (name, then each base field's type and name in wire order, array length as a byte; extension
// fields left out), and the wire offsets of ODOMETRY's fields.
#include "core/mavlink/messages.hpp"

#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "core/mavlink/crc_x25.hpp"

using namespace ums::mavlink;

namespace {

struct Field {
  const char* type;
  const char* name;
  int array = 0;
};

std::uint8_t crc_extra_of(const char* message, const std::vector<Field>& base_fields_in_wire_order) {
  auto add = [](std::uint16_t crc, const std::string& s) {
    for (char c : s) crc = crc_accumulate(static_cast<std::uint8_t>(c), crc);
    return crc;
  };
  std::uint16_t crc = add(kCrcInit, std::string(message) + " ");
  for (const Field& f : base_fields_in_wire_order) {
    crc = add(crc, std::string(f.type) + " ");
    crc = add(crc, std::string(f.name) + " ");
    if (f.array > 0) crc = crc_accumulate(static_cast<std::uint8_t>(f.array), crc);
  }
  return static_cast<std::uint8_t>((crc & 0xFF) ^ (crc >> 8));
}

}  // namespace

TEST_CASE("CRC_EXTRA of each message follows from its field list", "[mavlink]") {
  CHECK(crc_extra_of("HEARTBEAT", {{"uint32_t", "custom_mode"}, {"uint8_t", "type"}, {"uint8_t", "autopilot"},
                                   {"uint8_t", "base_mode"}, {"uint8_t", "system_status"},
                                   {"uint8_t", "mavlink_version"}}) == kHeartbeat.crc_extra);
  CHECK(crc_extra_of("ODOMETRY", {{"uint64_t", "time_usec"}, {"float", "x"}, {"float", "y"}, {"float", "z"},
                                  {"float", "q", 4}, {"float", "vx"}, {"float", "vy"}, {"float", "vz"},
                                  {"float", "rollspeed"}, {"float", "pitchspeed"}, {"float", "yawspeed"},
                                  {"float", "pose_covariance", 21}, {"float", "velocity_covariance", 21},
                                  {"uint8_t", "frame_id"}, {"uint8_t", "child_frame_id"}}) == kOdometry.crc_extra);
  CHECK(crc_extra_of("VISION_POSITION_ESTIMATE", {{"uint64_t", "usec"}, {"float", "x"}, {"float", "y"},
                                                  {"float", "z"}, {"float", "roll"}, {"float", "pitch"},
                                                  {"float", "yaw"}}) == kVisionPositionEstimate.crc_extra);
  CHECK(crc_extra_of("VISION_SPEED_ESTIMATE", {{"uint64_t", "usec"}, {"float", "x"}, {"float", "y"},
                                               {"float", "z"}}) == kVisionSpeedEstimate.crc_extra);
  CHECK(crc_extra_of("TIMESYNC", {{"int64_t", "tc1"}, {"int64_t", "ts1"}}) == kTimesync.crc_extra);
}

TEST_CASE("ODOMETRY puts each field at its wire offset, unknown covariances start with NaN", "[mavlink]") {
  Odometry m;
  m.time_usec = 123456789;
  m.x = 1.5f;
  m.q[3] = 0.25f;
  m.vz = -2.0f;
  m.yawspeed = 0.5f;
  m.reset_counter = 9;
  m.quality = -1;
  PayloadWriter w;
  encode(m, &w);
  const PayloadReader r(w.data(), kOdometry.len);
  CHECK(r.u64(0) == 123456789u);
  CHECK(r.f32(8) == 1.5f);
  CHECK(r.f32(20) == 1.0f);   // q w
  CHECK(r.f32(32) == 0.25f);  // q z
  CHECK(r.f32(44) == -2.0f);
  CHECK(r.f32(56) == 0.5f);
  CHECK(std::isnan(r.f32(60)));
  CHECK(r.f32(64) == 0.0f);
  CHECK(std::isnan(r.f32(144)));
  CHECK(r.u8(228) == kFrameLocalFrd);
  CHECK(r.u8(229) == kFrameBodyFrd);
  CHECK(r.u8(230) == 9);
  CHECK(r.u8(231) == kEstimatorTypeVio);
  CHECK(static_cast<std::int8_t>(r.u8(232)) == -1);
}

TEST_CASE("TIMESYNC encodes and decodes to the same values", "[mavlink]") {
  Timesync t;
  t.tc1 = -42;
  t.ts1 = 1'700'000'000'123'456'789LL;
  t.target_system = 1;
  t.target_component = 190;
  PayloadWriter w;
  encode(t, &w);
  const Timesync back = decode_timesync(PayloadReader(w.data(), kTimesync.len));
  CHECK(back.tc1 == t.tc1);
  CHECK(back.ts1 == t.ts1);
  CHECK(back.target_system == 1);
  CHECK(back.target_component == 190);
}
