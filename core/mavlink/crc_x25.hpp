#pragma once
// The checksum of MAVLink frames: CRC-16/MCRF4XX (X.25's accumulate step, initial value 0xFFFF,
// no final XOR). "123456789" gives 0x6F91. Also the per-message CRC_EXTRA seed, which a receiver
// uses to refuse a message whose field layout differs from its own definition.

#include <cstddef>
#include <cstdint>

namespace ums::mavlink {

constexpr std::uint16_t kCrcInit = 0xFFFF;

constexpr std::uint16_t crc_accumulate(std::uint8_t byte, std::uint16_t crc) {
  std::uint8_t tmp = static_cast<std::uint8_t>(byte ^ static_cast<std::uint8_t>(crc & 0xFF));
  tmp = static_cast<std::uint8_t>(tmp ^ static_cast<std::uint8_t>(tmp << 4));
  return static_cast<std::uint16_t>((crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4));
}

constexpr std::uint16_t crc_x25(const std::uint8_t* data, std::size_t n, std::uint16_t crc = kCrcInit) {
  for (std::size_t i = 0; i < n; ++i) crc = crc_accumulate(data[i], crc);
  return crc;
}

}  // namespace ums::mavlink
