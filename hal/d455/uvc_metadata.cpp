#include "hal/d455/uvc_metadata.hpp"

#include <cstring>

namespace ums::d455 {

namespace {
template <typename T>
T load_le(const std::uint8_t* p) {
  T v{};
  std::memcpy(&v, p, sizeof(T));  // the boards we target are little endian, like the wire format
  return v;
}
}  // namespace

bool parse_uvc_metadata(const std::uint8_t* data, std::size_t size, UvcFrameMeta* out) {
  *out = UvcFrameMeta{};
  constexpr std::size_t kKernelHeader = 10;  // u64 ns + u16 sof
  if (size < kKernelHeader + 2) return false;
  out->host_ns = load_le<std::uint64_t>(data);
  const std::uint8_t* h = data + kKernelHeader;
  const std::size_t header_len = h[0];
  const std::uint8_t info = h[1];
  if (header_len < 2 || kKernelHeader + header_len > size) return false;
  std::size_t pos = 2;
  if (info & 0x04) {  // bmHeaderInfo bit 2: PTS present
    if (pos + 4 > header_len) return false;
    out->has_pts = true;
    out->pts_us = load_le<std::uint32_t>(h + pos);
    pos += 4;
  }
  if (info & 0x08) {  // bit 3: SCR present (u32 STC + u16 SOF)
    if (pos + 6 > header_len) return false;
    pos += 6;
  }
  // Intel blocks follow in the rest of the payload header (D4XX format only).
  while (pos + 8 <= header_len) {
    const auto id = load_le<std::uint32_t>(h + pos);
    const auto block_size = load_le<std::uint32_t>(h + pos + 4);
    if (block_size < 8 || pos + block_size > header_len) return false;
    const std::uint8_t* b = h + pos;
    if (id == kD4xxCaptureTimingId && block_size >= 32) {
      const auto flags = load_le<std::uint32_t>(b + 12);
      if ((flags & 0x3u) == 0x3u) {  // frame_counter and sensor_timestamp valid
        out->has_capture_timing = true;
        out->frame_counter = load_le<std::uint32_t>(b + 16);
        out->sensor_offset_us = load_le<std::uint32_t>(b + 20);
        if (flags & 0x8u) out->exposure_us = load_le<std::uint32_t>(b + 28);
      }
    } else if (id == kD4xxDepthControlId && block_size >= 57) {
      out->has_emitter_mode = true;
      out->emitter_mode = b[56];
    }
    pos += block_size;
  }
  return true;
}

}  // namespace ums::d455
