// MAVLink v2 framing: the checksum, the header, truncation and the sequence counter.
#include "core/mavlink/frame_v2.hpp"

#include <catch2/catch.hpp>
#include <cstring>

#include "core/mavlink/crc_x25.hpp"
#include "core/mavlink/messages.hpp"

using namespace ums::mavlink;

TEST_CASE("crc_x25 is CRC-16/MCRF4XX: the check value of \"123456789\" is 0x6F91", "[mavlink]") {
  const char* text = "123456789";
  CHECK(crc_x25(reinterpret_cast<const std::uint8_t*>(text), std::strlen(text)) == 0x6F91);
}

TEST_CASE("frame_message writes the v2 header, the payload and a CRC seeded with CRC_EXTRA", "[mavlink]") {
  Sender sender;
  sender.system_id = 7;
  sender.component_id = 197;
  sender.sequence = 254;
  PayloadWriter payload;
  encode(Heartbeat{}, &payload);
  std::uint8_t out[kMaxFrameBytes];
  const std::size_t n = frame_message(kHeartbeat, payload, &sender, out);
  REQUIRE(n == kHeaderBytes + 9 + 2);
  CHECK(out[0] == 0xFD);
  CHECK(out[1] == 9);
  CHECK(out[2] == 0);
  CHECK(out[3] == 0);
  CHECK(out[4] == 254);
  CHECK(out[5] == 7);
  CHECK(out[6] == 197);
  CHECK((out[7] | out[8] << 8 | out[9] << 16) == 0);
  CHECK(out[10 + 4] == kTypeOnboardController);
  CHECK(out[10 + 8] == 3);  // mavlink_version
  std::uint16_t crc = crc_x25(out + 1, 9 + 9);
  crc = crc_accumulate(kHeartbeat.crc_extra, crc);
  CHECK(out[n - 2] == (crc & 0xFF));
  CHECK(out[n - 1] == (crc >> 8));
  // The sequence wraps at 256.
  frame_message(kHeartbeat, payload, &sender, out);
  CHECK(out[4] == 255);
  frame_message(kHeartbeat, payload, &sender, out);
  CHECK(out[4] == 0);
}

TEST_CASE("frame_message drops trailing zero bytes of the payload but keeps one", "[mavlink]") {
  Sender sender;
  std::uint8_t out[kMaxFrameBytes];
  PayloadWriter zeros;
  CHECK(frame_message(kTimesync, zeros, &sender, out) == kHeaderBytes + 1 + 2);
  CHECK(out[1] == 1);
  Timesync t;
  t.tc1 = 5;
  t.ts1 = 0x0102;  // bytes 8, 9 set; targets zero
  PayloadWriter w;
  encode(t, &w);
  CHECK(frame_message(kTimesync, w, &sender, out) == kHeaderBytes + 10 + 2);
  Odometry m;  // quality 0 is the last byte: ODOMETRY truncates to 232 bytes
  PayloadWriter o;
  encode(m, &o);
  frame_message(kOdometry, o, &sender, out);
  CHECK(out[1] == 232);
  CHECK((out[7] | out[8] << 8 | out[9] << 16) == 331);
}

TEST_CASE("PayloadWriter is little-endian whatever the machine", "[mavlink]") {
  PayloadWriter w;
  w.u32(0, 0x11223344u);
  w.u64(4, 0x0102030405060708ull);
  w.f32(12, 1.0f);  // 0x3F800000
  const std::uint8_t want[] = {0x44, 0x33, 0x22, 0x11, 8, 7, 6, 5, 4, 3, 2, 1, 0, 0, 0x80, 0x3F};
  CHECK(std::memcmp(w.data(), want, sizeof(want)) == 0);
  PayloadReader r(w.data(), 16);
  CHECK(r.u32(0) == 0x11223344u);
  CHECK(r.u64(4) == 0x0102030405060708ull);
  CHECK(r.f32(12) == 1.0f);
  CHECK(r.u8(200) == 0);  // zero-filled past the length
}
