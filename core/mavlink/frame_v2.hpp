#pragma once
// MAVLink v2 framing of one message (unsigned): magic 0xFD, len, incompat 0, compat 0, seq,
// sysid, compid, 24-bit msgid, the payload with its trailing zero bytes removed (at least one
// byte kept, as the protocol requires), then the X.25 CRC over everything after the magic plus
// the message's CRC_EXTRA. Payload fields are little-endian and written byte by byte, so the
// encoding is the same on every architecture. Nothing here allocates.

#include <cstddef>
#include <cstdint>

namespace ums::mavlink {

// What a receiver needs to know of one message type (from the message definition XML).
struct MessageSpec {
  std::uint32_t id;
  std::uint8_t crc_extra;
  std::uint8_t min_len;  // base fields only
  std::uint8_t len;      // with the extension fields
};

constexpr std::size_t kHeaderBytes = 10;
constexpr std::size_t kMaxPayloadBytes = 255;
constexpr std::size_t kMaxFrameBytes = kHeaderBytes + kMaxPayloadBytes + 2;  // unsigned

// Little-endian field writer over a fixed payload buffer (zeroed at construction).
class PayloadWriter {
 public:
  PayloadWriter();
  void u8(std::size_t offset, std::uint8_t v);
  void i8(std::size_t offset, std::int8_t v) { u8(offset, static_cast<std::uint8_t>(v)); }
  void u16(std::size_t offset, std::uint16_t v);
  void u32(std::size_t offset, std::uint32_t v);
  void u64(std::size_t offset, std::uint64_t v);
  void i64(std::size_t offset, std::int64_t v) { u64(offset, static_cast<std::uint64_t>(v)); }
  void f32(std::size_t offset, float v);
  const std::uint8_t* data() const { return bytes_; }

 private:
  std::uint8_t bytes_[kMaxPayloadBytes];
};

// Little-endian field reader over a received payload (zero-filled past its length).
class PayloadReader {
 public:
  PayloadReader(const std::uint8_t* payload, std::size_t len);
  std::uint8_t u8(std::size_t offset) const { return bytes_[offset]; }
  std::uint64_t u64(std::size_t offset) const;
  std::int64_t i64(std::size_t offset) const { return static_cast<std::int64_t>(u64(offset)); }
  std::uint32_t u32(std::size_t offset) const;
  float f32(std::size_t offset) const;

 private:
  std::uint8_t bytes_[kMaxPayloadBytes];
};

// The sender's identity and packet counter.
struct Sender {
  std::uint8_t system_id = 1;
  std::uint8_t component_id = 197;  // MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY
  std::uint8_t sequence = 0;        // of the next frame
};

// Frames spec.len payload bytes into out (at least kMaxFrameBytes); returns the frame's size
// and advances the sender's sequence.
std::size_t frame_message(const MessageSpec& spec, const PayloadWriter& payload, Sender* sender,
                          std::uint8_t* out);

}  // namespace ums::mavlink
