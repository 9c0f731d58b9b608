#include "core/frontend/image_pyramid.hpp"

#include <algorithm>
#include <cstdint>
#include <cmath>
#include <stdexcept>

#include <catch2/catch.hpp>

#include "profiling/alloc_counter.hpp"
#include "tests/core/frontend/synthetic_images.hpp"

TEST_CASE("pyramid levels halve the size (rounding up) and keep a constant image constant") {
  ums::ImagePyramid pyr(752, 480, 4);
  ums::test::GreyImage img(752, 480, 77);
  REQUIRE(pyr.build(img.view()) == ums::Status::kOk);
  const int w[4] = {752, 376, 188, 94}, h[4] = {480, 240, 120, 60};
  for (int l = 0; l < 4; ++l) {
    CHECK(pyr.level(l).width == w[l]);
    CHECK(pyr.level(l).height == h[l]);
    for (int y = 0; y < pyr.level(l).height; y += 7)
      for (int x = 0; x < pyr.level(l).width; x += 5) REQUIRE(pyr.level(l).row(y)[x] == 77);
  }
  ums::ImagePyramid odd(101, 51, 3);
  CHECK(odd.level(1).width == 51);
  CHECK(odd.level(2).height == 13);
}

TEST_CASE("pyramid level 1 of a linear ramp samples the ramp at twice the coordinate") {
  ums::test::GreyImage img(200, 100);
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 200; ++x) img.at(x, y) = static_cast<std::uint8_t>(x);
  ums::ImagePyramid pyr(200, 100, 2);
  REQUIRE(pyr.build(img.view()) == ums::Status::kOk);
  // Away from the borders the symmetric kernel keeps a linear ramp exact: value = 2x.
  for (int x = 2; x < 98; ++x) CHECK(std::abs(pyr.level(1).row(20)[x] - 2 * x) <= 1);
}

TEST_CASE("a white image stays white on every level: the largest sums fit the 16-bit lanes") {
  // 16 * 255 per column, times 16 across, plus 128 for the rounding: 65,408, just below 2^16.
  ums::test::GreyImage img(100, 40, 255);
  ums::ImagePyramid pyr(100, 40, 3);
  REQUIRE(pyr.build(img.view()) == ums::Status::kOk);
  int not_white = 0;
  for (int l = 1; l < 3; ++l) {
    const ums::ImageView& v = pyr.level(l);
    for (int y = 0; y < v.height; ++y)
      for (int x = 0; x < v.width; ++x) not_white += v.row(y)[x] != 255 ? 1 : 0;
  }
  CHECK(not_white == 0);
}

TEST_CASE("pyramid levels equal the direct clamped 5x5 binomial formula at every pixel, any size") {
  // Widths and heights of every parity, down to 1 px: the border columns and rows take the
  // clamped path, the rest the unclamped loops (which the compiler vectorizes: rows up to 848 wide).
  const int sizes[][2] = {{1, 1}, {2, 3}, {3, 2}, {4, 5}, {5, 4}, {6, 7}, {9, 6}, {37, 23}, {64, 48}, {101, 51}, {752, 48}, {767, 31}, {848, 17}};
  for (const auto& sz : sizes) {
    const int w = sz[0], h = sz[1];
    const ums::test::GreyImage img = ums::test::random_image(w, h, 2463534242u + static_cast<std::uint32_t>(w * 1000 + h));
    ums::ImagePyramid pyr(w, h, 3);
    REQUIRE(pyr.build(img.view()) == ums::Status::kOk);
    int mismatches = 0;
    for (int l = 1; l < 3; ++l) {
      const ums::ImageView& a = pyr.level(l - 1);
      const ums::ImageView& b = pyr.level(l);
      const int k5[5] = {1, 4, 6, 4, 1};
      for (int y = 0; y < b.height; ++y) {
        for (int x = 0; x < b.width; ++x) {
          int acc = 0;
          for (int j = 0; j < 5; ++j) {
            const std::uint8_t* r = a.row(std::clamp(2 * y + j - 2, 0, a.height - 1));
            for (int i = 0; i < 5; ++i) acc += k5[j] * k5[i] * r[std::clamp(2 * x + i - 2, 0, a.width - 1)];
          }
          mismatches += b.row(y)[x] != static_cast<std::uint8_t>((acc + 128) >> 8) ? 1 : 0;
        }
      }
    }
    INFO(w << "x" << h);
    CHECK(mismatches == 0);
  }
}

TEST_CASE("every level's margin holds the pixel at the clamped coordinates, any size, and margin 0 packs the rows") {
  // Sizes of every parity down to 1 px, so that coarse levels are narrower than the margin.
  const int sizes[][2] = {{1, 1}, {2, 3}, {5, 4}, {37, 23}, {101, 51}, {848, 17}};
  for (const auto& sz : sizes) {
    const int w = sz[0], h = sz[1];
    const ums::test::GreyImage img = ums::test::random_image(w, h, 88172645u + static_cast<std::uint32_t>(w * 1000 + h));
    for (const int margin : {ums::capacity::kPyramidMarginPx, 7}) {
      ums::ImagePyramid pyr(w, h, 3, margin);
      ums::ImagePyramid packed(w, h, 3, 0);
      REQUIRE(pyr.build(img.view()) == ums::Status::kOk);
      REQUIRE(packed.build(img.view()) == ums::Status::kOk);
      int mismatches = 0, read = 0;
      for (int l = 0; l < 3; ++l) {
        const ums::ImageView& v = pyr.level(l);
        const ums::ImageView& p = packed.level(l);
        REQUIRE(v.margin == margin);
        REQUIRE(p.margin == 0);
        REQUIRE(p.stride == p.width);
        for (int y = -margin; y < v.height + margin; ++y) {
          for (int x = -margin; x < v.width + margin; ++x) {
            const std::uint8_t clamped = p.row(std::clamp(y, 0, p.height - 1))[std::clamp(x, 0, p.width - 1)];
            mismatches += v.row(y)[x] != clamped ? 1 : 0;
            ++read;
          }
        }
      }
      INFO(w << "x" << h << " margin " << margin << ": " << read << " pixels");
      CHECK(mismatches == 0);
    }
  }
  CHECK_THROWS_AS(ums::ImagePyramid(64, 48, 4, ums::capacity::kPyramidMarginPx + 1), std::runtime_error);
  CHECK_THROWS_AS(ums::ImagePyramid(64, 48, 4, -1), std::runtime_error);
}

TEST_CASE("pyramid rejects a wrong-size image and sizes beyond capacity, and build allocates nothing") {
  ums::ImagePyramid pyr(64, 48, 4);
  ums::test::GreyImage wrong(65, 48);
  CHECK(pyr.build(wrong.view()) == ums::Status::kInvalidInput);
  CHECK_THROWS_AS(ums::ImagePyramid(100000, 10, 4), std::runtime_error);
  CHECK_THROWS_AS(ums::ImagePyramid(64, 48, 9), std::runtime_error);
  ums::test::GreyImage ok(64, 48, 3);
  ums::AllocScope scope;
  const ums::Status s = pyr.build(ok.view());
  const std::uint64_t allocs = scope.allocations();
  REQUIRE(s == ums::Status::kOk);
  if (ums::alloc_counter_available()) CHECK(allocs == 0);
}
