#include "hal/d455/y8i.hpp"

#include <catch2/catch.hpp>

#include <vector>

#include "profiling/alloc_counter.hpp"

using ums::d455::deinterleave_y8i;
using ums::d455::deinterleave_y8i_scalar;

TEST_CASE("Y8I de-interleave puts byte 0 left and byte 1 right at 848x480, allocation-free", "[d455][y8i]") {
  const int w = 848, h = 480, src_stride = 2 * w + 32;  // padded rows must be skipped
  std::vector<std::uint8_t> src(static_cast<std::size_t>(src_stride) * h, 0xEE);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      src[static_cast<std::size_t>(y * src_stride + 2 * x)] = static_cast<std::uint8_t>((x * 7 + y) & 255);
      src[static_cast<std::size_t>(y * src_stride + 2 * x + 1)] = static_cast<std::uint8_t>((x + y * 13) & 255);
    }
  }
  std::vector<std::uint8_t> left(static_cast<std::size_t>(w) * h), right(static_cast<std::size_t>(w) * h);
  ums::AllocScope scope;
  deinterleave_y8i(src.data(), w, h, src_stride, left.data(), w, right.data(), w);
  REQUIRE(scope.allocations() == 0);
  int wrong = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      wrong += left[static_cast<std::size_t>(y * w + x)] != static_cast<std::uint8_t>((x * 7 + y) & 255);
      wrong += right[static_cast<std::size_t>(y * w + x)] != static_cast<std::uint8_t>((x + y * 13) & 255);
    }
  }
  REQUIRE(wrong == 0);
}

TEST_CASE("Y8I vector path equals the scalar path for widths that are not multiples of 16", "[d455][y8i]") {
  for (int w : {1, 15, 17, 33, 640}) {
    const int h = 3;
    std::vector<std::uint8_t> src(static_cast<std::size_t>(2 * w * h));
    for (std::size_t i = 0; i < src.size(); ++i) src[i] = static_cast<std::uint8_t>(i * 31 + 7);
    std::vector<std::uint8_t> l1(static_cast<std::size_t>(w * h)), r1(l1.size()), l2(l1.size()), r2(l1.size());
    deinterleave_y8i(src.data(), w, h, 2 * w, l1.data(), w, r1.data(), w);
    deinterleave_y8i_scalar(src.data(), w, h, 2 * w, l2.data(), w, r2.data(), w);
    CHECK(l1 == l2);
    CHECK(r1 == r2);
    CHECK(l1[0] == src[0]);
    CHECK(r1[0] == src[1]);
  }
}
