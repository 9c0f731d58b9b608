#include "core/mavlink/frame_v2.hpp"

#include <cstring>

#include "core/mavlink/crc_x25.hpp"

namespace ums::mavlink {

PayloadWriter::PayloadWriter() { std::memset(bytes_, 0, sizeof(bytes_)); }

void PayloadWriter::u8(std::size_t offset, std::uint8_t v) { bytes_[offset] = v; }

void PayloadWriter::u16(std::size_t offset, std::uint16_t v) {
  for (std::size_t i = 0; i < 2; ++i) bytes_[offset + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

void PayloadWriter::u32(std::size_t offset, std::uint32_t v) {
  for (std::size_t i = 0; i < 4; ++i) bytes_[offset + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

void PayloadWriter::u64(std::size_t offset, std::uint64_t v) {
  for (std::size_t i = 0; i < 8; ++i) bytes_[offset + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

void PayloadWriter::f32(std::size_t offset, float v) {
  std::uint32_t bits = 0;
  static_assert(sizeof(bits) == sizeof(v), "IEEE-754 single precision expected");
  std::memcpy(&bits, &v, sizeof(bits));
  u32(offset, bits);
}

PayloadReader::PayloadReader(const std::uint8_t* payload, std::size_t len) {
  std::memset(bytes_, 0, sizeof(bytes_));
  std::memcpy(bytes_, payload, len < sizeof(bytes_) ? len : sizeof(bytes_));
}

std::uint64_t PayloadReader::u64(std::size_t offset) const {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < 8; ++i) v |= static_cast<std::uint64_t>(bytes_[offset + i]) << (8 * i);
  return v;
}

std::uint32_t PayloadReader::u32(std::size_t offset) const {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(bytes_[offset + i]) << (8 * i);
  return v;
}

float PayloadReader::f32(std::size_t offset) const {
  const std::uint32_t bits = u32(offset);
  float v = 0.0f;
  std::memcpy(&v, &bits, sizeof(v));
  return v;
}

std::size_t frame_message(const MessageSpec& spec, const PayloadWriter& payload, Sender* sender,
                          std::uint8_t* out) {
  std::size_t len = spec.len;
  while (len > 1 && payload.data()[len - 1] == 0) --len;  // truncation: receivers zero-fill
  out[0] = 0xFD;
  out[1] = static_cast<std::uint8_t>(len);
  out[2] = 0;  // incompat_flags: not signed
  out[3] = 0;  // compat_flags
  out[4] = sender->sequence++;
  out[5] = sender->system_id;
  out[6] = sender->component_id;
  out[7] = static_cast<std::uint8_t>(spec.id & 0xFF);
  out[8] = static_cast<std::uint8_t>((spec.id >> 8) & 0xFF);
  out[9] = static_cast<std::uint8_t>((spec.id >> 16) & 0xFF);
  std::memcpy(out + kHeaderBytes, payload.data(), len);
  std::uint16_t crc = crc_x25(out + 1, kHeaderBytes - 1 + len);
  crc = crc_accumulate(spec.crc_extra, crc);
  out[kHeaderBytes + len] = static_cast<std::uint8_t>(crc & 0xFF);
  out[kHeaderBytes + len + 1] = static_cast<std::uint8_t>(crc >> 8);
  return kHeaderBytes + len + 2;
}

}  // namespace ums::mavlink
