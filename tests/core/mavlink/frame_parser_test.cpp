// Receiving frames: whole frames accepted, corrupted ones and other messages counted, the
// stream resynchronised on the next magic byte.
#include "core/mavlink/frame_parser.hpp"

#include <catch2/catch.hpp>
#include <vector>

#include "core/mavlink/crc_x25.hpp"
#include "core/mavlink/messages.hpp"

using namespace ums::mavlink;

namespace {

const MessageSpec kSpecs[] = {kTimesync, kHeartbeat};

std::vector<std::uint8_t> timesync_frame(std::int64_t ts1, Sender* sender, const MessageSpec& spec = kTimesync) {
  Timesync t;
  t.ts1 = ts1;
  PayloadWriter w;
  encode(t, &w);
  std::uint8_t out[kMaxFrameBytes];
  const std::size_t n = frame_message(spec, w, sender, out);
  return {out, out + n};
}

int push_all(FrameParser* p, const std::vector<std::uint8_t>& bytes, std::vector<std::int64_t>* ts1) {
  int accepted = 0;
  for (std::uint8_t b : bytes) {
    if (!p->push(b)) continue;
    ++accepted;
    const ReceivedMessage& m = p->message();
    ts1->push_back(decode_timesync(PayloadReader(m.payload, m.len)).ts1);
  }
  return accepted;
}

}  // namespace

TEST_CASE("FrameParser accepts back-to-back frames with garbage between them", "[mavlink]") {
  Sender sender;
  sender.system_id = 3;
  std::vector<std::uint8_t> stream = {0x00, 0x55};
  for (std::int64_t ts : {11, 22, 33}) {
    const auto f = timesync_frame(ts, &sender);
    stream.insert(stream.end(), f.begin(), f.end());
    stream.push_back(0x42);
  }
  FrameParser p(kSpecs, 2);
  std::vector<std::int64_t> ts1;
  CHECK(push_all(&p, stream, &ts1) == 3);
  CHECK(ts1 == std::vector<std::int64_t>{11, 22, 33});
  CHECK(p.message().system_id == 3);
  CHECK(p.counters().skipped_bytes == 5);
}

TEST_CASE("FrameParser refuses a frame with a flipped bit and one of a message it does not know", "[mavlink]") {
  Sender sender;
  auto bad = timesync_frame(7, &sender);
  bad[12] ^= 0x04;
  const auto other = timesync_frame(8, &sender, kOdometry);  // ODOMETRY's id: not in the table
  const auto good = timesync_frame(9, &sender);
  std::vector<std::uint8_t> stream(bad);
  stream.insert(stream.end(), other.begin(), other.end());
  stream.insert(stream.end(), good.begin(), good.end());
  FrameParser p(kSpecs, 2);
  std::vector<std::int64_t> ts1;
  CHECK(push_all(&p, stream, &ts1) == 1);
  CHECK(ts1 == std::vector<std::int64_t>{9});
  CHECK(p.counters().bad_crc == 1);
  CHECK(p.counters().unknown_id == 1);
}

TEST_CASE("FrameParser skips the 13-byte signature of a signed frame", "[mavlink]") {
  Sender sender;
  auto signed_frame = timesync_frame(5, &sender);
  signed_frame[2] = 0x01;  // incompat flag: signed; the CRC covers it, so compute it again
  const std::size_t len = signed_frame[1];
  std::uint16_t crc = crc_x25(signed_frame.data() + 1, kHeaderBytes - 1 + len);
  crc = crc_accumulate(kTimesync.crc_extra, crc);
  signed_frame[kHeaderBytes + len] = static_cast<std::uint8_t>(crc & 0xFF);
  signed_frame[kHeaderBytes + len + 1] = static_cast<std::uint8_t>(crc >> 8);
  for (int i = 0; i < 13; ++i) signed_frame.push_back(0xFD);  // a signature full of magic bytes
  const auto next = timesync_frame(6, &sender);
  signed_frame.insert(signed_frame.end(), next.begin(), next.end());
  FrameParser p(kSpecs, 2);
  std::vector<std::int64_t> ts1;
  CHECK(push_all(&p, signed_frame, &ts1) == 2);
  CHECK(ts1 == std::vector<std::int64_t>{5, 6});
  CHECK(p.counters().bad_crc == 0);
}
