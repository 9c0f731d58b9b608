#include "core/loop/brief.hpp"

namespace ums::loop {
namespace {

// xorshift64*: a fixed, portable sequence.
struct Rng {
  std::uint64_t s;
  std::uint32_t next() {
    s ^= s >> 12;
    s ^= s << 25;
    s ^= s >> 27;
    return static_cast<std::uint32_t>((s * 2685821657736338717ULL) >> 32);
  }
};

// A Gaussian of sigma 6.2 px rounded to an integer offset within +-15, from the sum of 12 uniform
// numbers (Irwin-Hall: mean 6, variance 1), in 1/65536 units: no libm, identical everywhere.
int gaussian_offset(Rng* rng) {
  for (;;) {
    std::int64_t sum = 0;
    for (int i = 0; i < 12; ++i) sum += rng->next() >> 16;  // 12 x U[0, 65536)
    const std::int64_t z_q16 = sum - 6 * 65536;             // N(0, 1) in 1/65536
    const std::int64_t v = (z_q16 * 62 / 10 + (z_q16 >= 0 ? 32768 : -32768)) / 65536;  // sigma 6.2, rounded
    if (v >= -BriefDescriber::kPatchRadius && v <= BriefDescriber::kPatchRadius) return static_cast<int>(v);
  }
}

}  // namespace

int hamming(const Descriptor& a, const Descriptor& b) {
  int d = 0;
  for (int i = 0; i < 4; ++i) d += __builtin_popcountll(a[i] ^ b[i]);
  return d;
}

BriefDescriber::BriefDescriber(int max_width, int max_height)
    : max_width_(max_width),
      max_height_(max_height),
      integral_(new std::uint32_t[static_cast<std::size_t>(max_width + 1) * static_cast<std::size_t>(max_height + 1)]) {
  Rng rng{0x9E3779B97F4A7C15ULL};
  for (Pair& p : pattern_) {
    for (;;) {
      p.x0 = static_cast<std::int8_t>(gaussian_offset(&rng));
      p.y0 = static_cast<std::int8_t>(gaussian_offset(&rng));
      p.x1 = static_cast<std::int8_t>(gaussian_offset(&rng));
      p.y1 = static_cast<std::int8_t>(gaussian_offset(&rng));
      if (p.x0 != p.x1 || p.y0 != p.y1) break;  // a point compared with itself says nothing
    }
  }
}

BriefDescriber::~BriefDescriber() = default;

bool BriefDescriber::set_image(const ImageView& image) {
  if (!image.valid() || image.width > max_width_ || image.height > max_height_) return false;
  width_ = image.width;
  height_ = image.height;
  const int w1 = width_ + 1;
  for (int x = 0; x <= width_; ++x) integral_[x] = 0;
  for (int y = 0; y < height_; ++y) {
    const std::uint8_t* row = image.row(y);
    std::uint32_t* above = &integral_[static_cast<std::size_t>(y) * w1];
    std::uint32_t* out = above + w1;
    out[0] = 0;
    std::uint32_t run = 0;
    for (int x = 0; x < width_; ++x) {
      run += row[x];
      out[x + 1] = above[x + 1] + run;
    }
  }
  return true;
}

int BriefDescriber::box_sum(int x, int y) const {
  const int w1 = width_ + 1;
  const int x0 = x - kBoxRadius, x1 = x + kBoxRadius + 1, y0 = y - kBoxRadius, y1 = y + kBoxRadius + 1;
  const std::size_t r0 = static_cast<std::size_t>(y0) * w1, r1 = static_cast<std::size_t>(y1) * w1;
  return static_cast<int>(integral_[r1 + x1] - integral_[r1 + x0] - integral_[r0 + x1] + integral_[r0 + x0]);
}

bool BriefDescriber::describe(float x_px, float y_px, Descriptor* out) const {
  const int x = static_cast<int>(x_px + 0.5f), y = static_cast<int>(y_px + 0.5f);
  if (x < kBorder || y < kBorder || x >= width_ - kBorder || y >= height_ - kBorder) return false;
  Descriptor d{0, 0, 0, 0};
  for (int i = 0; i < 256; ++i) {
    const Pair& p = pattern_[i];
    if (box_sum(x + p.x0, y + p.y0) < box_sum(x + p.x1, y + p.y1)) d[i >> 6] |= 1ULL << (i & 63);
  }
  *out = d;
  return true;
}

}  // namespace ums::loop
