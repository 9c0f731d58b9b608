#pragma once
// Receives MAVLink v2 frames from a byte stream, one byte at a time, for the few messages the
// product answers (TIMESYNC) or watches (HEARTBEAT). Frames of other messages, v1 frames, and
// frames with a wrong CRC are skipped and counted; a signed frame's signature is skipped, not
// checked. Fixed memory, no allocation.

#include <cstddef>
#include <cstdint>

#include "core/mavlink/frame_v2.hpp"

namespace ums::mavlink {

struct ReceivedMessage {
  std::uint32_t id = 0;
  std::uint8_t system_id = 0;
  std::uint8_t component_id = 0;
  std::uint8_t len = 0;
  std::uint8_t payload[kMaxPayloadBytes] = {};
};

struct ParserCounters {
  std::uint64_t accepted = 0;
  std::uint64_t bad_crc = 0;
  std::uint64_t unknown_id = 0;  // well-formed frames of messages not in the table (not checked)
  std::uint64_t skipped_bytes = 0;
};

class FrameParser {
 public:
  // specs: the messages to accept (their CRC_EXTRA is needed to check the CRC); not owned.
  FrameParser(const MessageSpec* specs, std::size_t n_specs);
  // Returns true when byte completes a valid frame of a known message (then message() holds it).
  bool push(std::uint8_t byte);
  const ReceivedMessage& message() const { return message_; }
  const ParserCounters& counters() const { return counters_; }

 private:
  const MessageSpec* find(std::uint32_t id) const;
  bool finish();

  const MessageSpec* specs_;
  std::size_t n_specs_;
  std::uint8_t frame_[kMaxFrameBytes + 13] = {};
  std::size_t have_ = 0;   // bytes of the current frame received
  std::size_t need_ = 0;   // its total size, known once the header is in
  ReceivedMessage message_;
  ParserCounters counters_;
};

}  // namespace ums::mavlink
