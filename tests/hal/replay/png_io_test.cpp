#include "hal/replay/png_io.hpp"

#include <png.h>

#include <catch2/catch.hpp>
#include <cstdio>
#include <fstream>
#include <vector>

#include "profiling/alloc_counter.hpp"
#include "tests/common/test_paths.hpp"

namespace {

using ums::ImageView;

std::vector<std::uint8_t> gradient(int w, int h) {
  std::vector<std::uint8_t> px(static_cast<std::size_t>(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) px[static_cast<std::size_t>(y) * w + x] = static_cast<std::uint8_t>((x * 7 + y * 3) & 0xff);
  return px;
}

// Writes a PNG of any libpng format from raw rows (test fixture; no error recovery needed).
void write_raw_png(const std::string& path, int w, int h, int bit_depth, int color_type,
                   const std::vector<std::uint8_t>& rows, int interlace = PNG_INTERLACE_NONE) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  REQUIRE(f != nullptr);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  png_init_io(png, f);
  png_set_IHDR(png, info, w, h, bit_depth, color_type, interlace, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  const std::size_t row_bytes = rows.size() / static_cast<std::size_t>(h);
  std::vector<png_bytep> pointers(h);
  for (int y = 0; y < h; ++y) pointers[y] = const_cast<png_bytep>(rows.data() + y * row_bytes);
  png_write_image(png, pointers.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  std::fclose(f);
}

}  // namespace

TEST_CASE("png round trip keeps every pixel, with a padded stride", "[png]") {
  const std::string dir = ums::test::make_temp_dir("png_round_trip");
  const int w = 37, h = 23, stride = 48;
  std::vector<std::uint8_t> padded(static_cast<std::size_t>(stride) * h, 0xAB);
  const auto px = gradient(w, h);
  for (int y = 0; y < h; ++y) std::copy(px.begin() + y * w, px.begin() + (y + 1) * w, padded.begin() + y * stride);
  std::string error;
  REQUIRE(ums::hal::write_png_gray8(dir + "/a.png", ImageView{padded.data(), w, h, stride}, &error));
  std::vector<std::uint8_t> out(w * h);
  int rw = 0, rh = 0;
  REQUIRE(ums::hal::read_png_gray8(dir + "/a.png", out.data(), out.size(), &rw, &rh, &error));
  CHECK(rw == w);
  CHECK(rh == h);
  CHECK(out == px);
}

TEST_CASE("png reader converts RGB, grey+alpha, 16-bit, palette-free 1-bit and interlaced to grey8", "[png]") {
  const std::string dir = ums::test::make_temp_dir("png_convert");
  const int w = 16, h = 8;
  const auto grey = gradient(w, h);
  std::vector<std::uint8_t> out(w * h);
  int rw = 0, rh = 0;
  std::string error;

  SECTION("RGB with equal channels gives the same grey") {
    std::vector<std::uint8_t> rgb;
    for (auto v : grey) rgb.insert(rgb.end(), {v, v, v});
    write_raw_png(dir + "/rgb.png", w, h, 8, PNG_COLOR_TYPE_RGB, rgb);
    REQUIRE(ums::hal::read_png_gray8(dir + "/rgb.png", out.data(), out.size(), &rw, &rh, &error));
    for (std::size_t i = 0; i < out.size(); ++i) REQUIRE(std::abs(out[i] - grey[i]) <= 1);
  }
  SECTION("grey+alpha drops alpha") {
    std::vector<std::uint8_t> ga;
    for (auto v : grey) ga.insert(ga.end(), {v, 0x40});
    write_raw_png(dir + "/ga.png", w, h, 8, PNG_COLOR_TYPE_GRAY_ALPHA, ga);
    REQUIRE(ums::hal::read_png_gray8(dir + "/ga.png", out.data(), out.size(), &rw, &rh, &error));
    CHECK(out == grey);
  }
  SECTION("16-bit grey is scaled to 8 bits") {
    std::vector<std::uint8_t> g16;  // big-endian samples v*257 scale back exactly to v
    for (auto v : grey) g16.insert(g16.end(), {v, v});
    write_raw_png(dir + "/g16.png", w, h, 16, PNG_COLOR_TYPE_GRAY, g16);
    REQUIRE(ums::hal::read_png_gray8(dir + "/g16.png", out.data(), out.size(), &rw, &rh, &error));
    CHECK(out == grey);
  }
  SECTION("1-bit grey expands to 0/255") {
    std::vector<std::uint8_t> bits(2 * h, 0xF0);  // 16 px per row = 2 bytes: 1111 0000 1111 0000
    write_raw_png(dir + "/g1.png", w, h, 1, PNG_COLOR_TYPE_GRAY, bits);
    REQUIRE(ums::hal::read_png_gray8(dir + "/g1.png", out.data(), out.size(), &rw, &rh, &error));
    CHECK(out[0] == 255);
    CHECK(out[4] == 0);
    CHECK(out[8] == 255);
  }
  SECTION("Adam7 interlaced grey") {
    write_raw_png(dir + "/adam7.png", w, h, 8, PNG_COLOR_TYPE_GRAY, grey, PNG_INTERLACE_ADAM7);
    REQUIRE(ums::hal::read_png_gray8(dir + "/adam7.png", out.data(), out.size(), &rw, &rh, &error));
    CHECK(out == grey);
  }
  CHECK(rw == w);
  CHECK(rh == h);
}

TEST_CASE("png reader reports missing, truncated, non-PNG and too-large files with the path", "[png]") {
  const std::string dir = ums::test::make_temp_dir("png_errors");
  const int w = 64, h = 32;
  const auto grey = gradient(w, h);
  std::string error;
  REQUIRE(ums::hal::write_png_gray8(dir + "/ok.png", ImageView{grey.data(), w, h, w}, &error));
  std::vector<std::uint8_t> out(w * h);
  int rw = 0, rh = 0;

  CHECK_FALSE(ums::hal::read_png_gray8(dir + "/missing.png", out.data(), out.size(), &rw, &rh, &error));
  CHECK_THAT(error, Catch::Contains("missing.png: cannot open"));

  {
    std::ifstream in(dir + "/ok.png", std::ios::binary);
    std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir + "/cut.png", std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  }
  CHECK_FALSE(ums::hal::read_png_gray8(dir + "/cut.png", out.data(), out.size(), &rw, &rh, &error));
  CHECK_THAT(error, Catch::Contains("cut.png: "));

  std::ofstream(dir + "/text.png") << "this is not a png\n";
  CHECK_FALSE(ums::hal::read_png_gray8(dir + "/text.png", out.data(), out.size(), &rw, &rh, &error));
  CHECK_THAT(error, Catch::Contains("text.png: ") && Catch::Contains("PNG"));

  CHECK_FALSE(ums::hal::read_png_gray8(dir + "/ok.png", out.data(), out.size() - 1, &rw, &rh, &error));
  CHECK_THAT(error, Catch::Contains("ok.png: image 64x32 does not fit"));

  CHECK_FALSE(ums::hal::write_png_gray8(dir + "/no/such/dir/x.png", ImageView{grey.data(), w, h, w}, &error));
  CHECK_THAT(error, Catch::Contains("x.png: cannot create"));
}

TEST_CASE("PngGrayReader decodes real EuRoC frames without heap allocation", "[png][alloc]") {
  const std::string path = ums::test::euroc_micro_dir() + "/mav0/cam0/data/1403715273262142976.png";
  ums::hal::PngGrayReader reader;
  std::vector<std::uint8_t> out(752 * 480);
  int w = 0, h = 0;
  char reason[128];
  REQUIRE(reader.read(path.c_str(), out.data(), out.size(), &w, &h, reason, sizeof(reason)));
  CHECK(w == 752);
  CHECK(h == 480);
  ums::AllocScope scope;
  for (int i = 0; i < 3; ++i) REQUIRE(reader.read(path.c_str(), out.data(), out.size(), &w, &h, reason, sizeof(reason)));
  if (ums::alloc_counter_available()) CHECK(scope.allocations() == 0);
  CHECK(reader.heap_fallbacks() == 0);
  // libpng + zlib working set for a 752-px grey image: well inside the arena.
  CHECK(reader.arena_high_water_bytes() > 0);
  CHECK(reader.arena_high_water_bytes() < reader.arena_bytes() / 2);
}
