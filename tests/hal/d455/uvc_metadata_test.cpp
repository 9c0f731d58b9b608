#include "hal/d455/uvc_metadata.hpp"

#include <catch2/catch.hpp>

#include <cstring>
#include <vector>

using namespace ums::d455;

namespace {
template <typename T>
void put(std::vector<std::uint8_t>& b, std::size_t at, T v) {
  if (b.size() < at + sizeof(T)) b.resize(at + sizeof(T));
  std::memcpy(b.data() + at, &v, sizeof(T));
}
// Kernel block + UVC header with PTS/SCR + capture timing (40 B) + depth control (60 B).
std::vector<std::uint8_t> d4xx_buffer(std::uint32_t pts, std::uint32_t offset_us, std::uint32_t counter, std::uint8_t emitter) {
  std::vector<std::uint8_t> b;
  put<std::uint64_t>(b, 0, 123456789ULL);
  put<std::uint16_t>(b, 8, 42);
  put<std::uint8_t>(b, 10, 112);
  put<std::uint8_t>(b, 11, 0x0E);
  put<std::uint32_t>(b, 12, pts);
  put<std::uint32_t>(b, 22, 0x80000001u);
  put<std::uint32_t>(b, 26, 40);
  put<std::uint32_t>(b, 34, 0x0Bu);
  put<std::uint32_t>(b, 38, counter);
  put<std::uint32_t>(b, 42, offset_us);
  put<std::uint32_t>(b, 50, 6951);
  put<std::uint32_t>(b, 62, 0x80000000u);
  put<std::uint32_t>(b, 66, 60);
  put<std::uint8_t>(b, 62 + 56, emitter);
  put<std::uint8_t>(b, 62 + 59, 0);
  return b;
}
}  // namespace

TEST_CASE("D4XX metadata: PTS, capture timing at meta+38/+42 and emitter mode are read by block walk", "[d455][meta]") {
  // FRAME_TS 179708225 and SENSOR_TS 179671458 from LRS doc/frame_metadata.md: offset 36767 µs.
  const auto b = d4xx_buffer(179708225u, 36767u, 991u, 1u);
  UvcFrameMeta m;
  REQUIRE(parse_uvc_metadata(b.data(), b.size(), &m));
  CHECK(m.host_ns == 123456789ULL);
  CHECK(m.has_pts);
  CHECK(m.pts_us == 179708225u);
  CHECK(m.has_capture_timing);
  CHECK(m.frame_counter == 991u);
  CHECK(m.pts_us - m.sensor_offset_us == 179671458u);
  CHECK(m.exposure_us == 6951u);
  CHECK(m.has_emitter_mode);
  CHECK(m.emitter_mode == 1);
}

TEST_CASE("UVCH metadata gives PTS only, and truncated or inconsistent buffers are refused", "[d455][meta]") {
  auto b = d4xx_buffer(5000u, 100u, 1u, 0u);
  b[10] = 12;  // UVCH: only the 12 standard header bytes
  b.resize(22);
  UvcFrameMeta m;
  REQUIRE(parse_uvc_metadata(b.data(), b.size(), &m));
  CHECK(m.has_pts);
  CHECK(m.pts_us == 5000u);
  CHECK_FALSE(m.has_capture_timing);
  CHECK_FALSE(m.has_emitter_mode);
  CHECK_FALSE(parse_uvc_metadata(b.data(), 15, &m));  // header says 12, buffer holds 5
  auto bad = d4xx_buffer(5000u, 100u, 1u, 0u);
  std::uint32_t huge = 500;
  std::memcpy(bad.data() + 26, &huge, 4);  // block larger than the header
  CHECK_FALSE(parse_uvc_metadata(bad.data(), bad.size(), &m));
}
