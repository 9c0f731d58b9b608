#pragma once
// Parse of one buffer of the UVC metadata node (V4L2_META_FMT_UVC 'UVCH' or V4L2_META_FMT_D4XX
// 'D4XX'): kernel block {u64 ns, u16 sof} then the UVC payload header {u8 length, u8 info, [u32 PTS],
// [u32 STC, u16 SOF]} and, for D4XX, Intel blocks {u32 id, u32 size incl. this 8-byte header, ...}
// walked by (id, size) (notes §2.4, §2.5; kernel metafmt-d4xx.rst). Little endian throughout.

#include <cstddef>
#include <cstdint>

namespace ums::d455 {

struct UvcFrameMeta {
  std::uint64_t host_ns = 0;           // kernel's host stamp of the payload header (uvc clock), ns
  bool has_pts = false;
  std::uint32_t pts_us = 0;            // UVC dwPresentationTime, device µs (readout start)
  bool has_capture_timing = false;     // D4XX block 0x80000001 with the fields below flagged valid
  std::uint32_t frame_counter = 0;
  std::uint32_t sensor_offset_us = 0;  // PTS - this = middle of exposure (LRS SENSOR_TIMESTAMP)
  std::uint32_t exposure_us = 0;
  bool has_emitter_mode = false;       // D4XX depth-control block 0x80000000
  std::uint8_t emitter_mode = 0;       // 0 = emitter off for this frame
};

inline constexpr std::uint32_t kD4xxCaptureTimingId = 0x80000001u;
inline constexpr std::uint32_t kD4xxDepthControlId = 0x80000000u;

// False when the buffer is too short for the header it announces (a malformed buffer).
bool parse_uvc_metadata(const std::uint8_t* data, std::size_t size, UvcFrameMeta* out);

}  // namespace ums::d455
