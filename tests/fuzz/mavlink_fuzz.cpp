// Bytes from the flight-controller link as MavlinkOutput::poll_incoming handles them: the MAVLink
// v2 frame parser with the messages the product accepts, and TIMESYNC decoding of what it accepts.
#include <cstddef>
#include <cstdint>

#include "core/mavlink/frame_parser.hpp"
#include "core/mavlink/messages.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const ums::mavlink::MessageSpec kReceived[] = {ums::mavlink::kHeartbeat, ums::mavlink::kTimesync};
  ums::mavlink::FrameParser parser(kReceived, sizeof(kReceived) / sizeof(kReceived[0]));
  for (std::size_t i = 0; i < size; ++i) {
    if (!parser.push(data[i]) || parser.message().id != ums::mavlink::kTimesync.id) continue;
    const ums::mavlink::ReceivedMessage& in = parser.message();
    (void)ums::mavlink::decode_timesync(ums::mavlink::PayloadReader(in.payload, in.len));
  }
  return 0;
}
