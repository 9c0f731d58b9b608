#include "core/frontend/image_pyramid.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

#if defined(__ARM_NEON)
#include <arm_neon.h>
#elif defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace ums {

ImagePyramid::ImagePyramid(int width, int height, int levels) : levels_(levels) {
  if (width <= 0 || height <= 0 || width > capacity::kMaxImageWidth || height > capacity::kMaxImageHeight) {
    throw std::runtime_error("ImagePyramid: image size " + std::to_string(width) + "x" + std::to_string(height) +
                             " outside 1.." + std::to_string(capacity::kMaxImageWidth) + "x" +
                             std::to_string(capacity::kMaxImageHeight));
  }
  if (levels < 1 || levels > capacity::kMaxPyramidLevels) {
    throw std::runtime_error("ImagePyramid: levels " + std::to_string(levels) + " outside 1.." +
                             std::to_string(capacity::kMaxPyramidLevels));
  }
  std::size_t total = 0;
  int w = width, h = height;
  for (int l = 0; l < levels; ++l) {
    total += static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
    w = std::max(1, (w + 1) / 2);
    h = std::max(1, (h + 1) / 2);
  }
  storage_.assign(total, 0);
  row_tmp_.assign(static_cast<std::size_t>(width) + kRowPad, 0);
  std::size_t offset = 0;
  w = width;
  h = height;
  for (int l = 0; l < levels; ++l) {
    ImageView& v = views_[l];
    v.data = storage_.data() + offset;
    v.width = w;
    v.height = h;
    v.stride = w;
    offset += static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
    w = std::max(1, (w + 1) / 2);
    h = std::max(1, (h + 1) / 2);
  }
}

namespace {

// o[x] for the 8 columns x .. x + 7 whose five taps lie inside the row: the horizontal pass on
// 16-bit lanes, integer arithmetic (the same values as the scalar loop, in any order). Reads
// t[2x - 2] .. t[2x + 17] (row_tmp has kRowPad elements past the widest row).
#if defined(__ARM_NEON)
inline void decimate8(const std::uint16_t* t, int x, std::uint8_t* o) {
  const uint16x8x2_t a = vld2q_u16(t + 2 * x - 2);  // t[2x - 2 + 2k], t[2x - 1 + 2k]
  const uint16x8x2_t b = vld2q_u16(t + 2 * x);      // t[2x + 2k],     t[2x + 1 + 2k]
  const uint16x8_t c = vld2q_u16(t + 2 * x + 2).val[0];
  uint16x8_t acc = vaddq_u16(vaddq_u16(a.val[0], c), vdupq_n_u16(128));
  acc = vaddq_u16(acc, vshlq_n_u16(vaddq_u16(a.val[1], b.val[1]), 2));
  acc = vmlaq_n_u16(acc, b.val[0], 6);
  vst1_u8(o + x, vshrn_n_u16(acc, 8));
}
#elif defined(__SSE2__)
inline void decimate8(const std::uint16_t* t, int x, std::uint8_t* o) {
  // The filter at the 16 full-resolution columns 2x .. 2x + 15, then their even ones.
  auto load = [t](int i) { return _mm_loadu_si128(reinterpret_cast<const __m128i*>(t + i)); };
  auto filtered = [&](int i) {  // columns i .. i + 7, then >> 8 (at most 255)
    const __m128i outer = _mm_add_epi16(load(i - 2), load(i + 2));
    const __m128i inner = _mm_slli_epi16(_mm_add_epi16(load(i - 1), load(i + 1)), 2);
    const __m128i mid = load(i);
    const __m128i six = _mm_add_epi16(_mm_slli_epi16(mid, 2), _mm_slli_epi16(mid, 1));
    const __m128i acc = _mm_add_epi16(_mm_add_epi16(outer, inner), _mm_add_epi16(six, _mm_set1_epi16(128)));
    return _mm_and_si128(_mm_srli_epi16(acc, 8), _mm_set1_epi32(0xFFFF));  // the even columns
  };
  const __m128i even = _mm_packs_epi32(filtered(2 * x), filtered(2 * x + 8));
  _mm_storel_epi64(reinterpret_cast<__m128i*>(o + x), _mm_packus_epi16(even, even));
}
#endif

// dst(x, y) = blur(src)(2x, 2y) with the 5-tap binomial kernel and replicated borders. The
// vertical pass runs first into row_tmp (sums up to 16*255 fit uint16), then the horizontal one.
void downsample(const ImageView& src, const ImageView& dst, std::uint16_t* row_tmp) {
  static constexpr int kW[5] = {1, 4, 6, 4, 1};
  const int sw = src.width, sh = src.height;
  auto* out_base = const_cast<std::uint8_t*>(dst.data);  // the pyramid owns these bytes
  for (int y = 0; y < dst.height; ++y) {
    const int sy = 2 * y;
    const std::uint8_t* rows[5];
    for (int k = 0; k < 5; ++k) rows[k] = src.row(std::clamp(sy + k - 2, 0, sh - 1));
    for (int x = 0; x < sw; ++x) {
      row_tmp[x] = static_cast<std::uint16_t>(rows[0][x] + 4 * rows[1][x] + 6 * rows[2][x] + 4 * rows[3][x] + rows[4][x]);
    }
    std::uint8_t* out = out_base + static_cast<long>(y) * dst.stride;
    // Columns whose five taps lie inside the row run in a loop of their own (no border test,
    // 16-bit lanes: 16 * 255 * 16 + 128 < 2^16); the one or two at each end clamp.
    const int x_lo = std::min(1, dst.width), x_hi = std::max(x_lo, std::min(dst.width, (sw - 1) / 2));
    auto clamped = [&](int x) {
      int acc = 0;
      for (int k = 0; k < 5; ++k) acc += kW[k] * row_tmp[std::clamp(2 * x + k - 2, 0, sw - 1)];
      out[x] = static_cast<std::uint8_t>((acc + 128) >> 8);
    };
    for (int x = 0; x < x_lo; ++x) clamped(x);
    const std::uint16_t* __restrict t = row_tmp;
    std::uint8_t* __restrict o = out;
    int xv = x_lo;
#if defined(__ARM_NEON) || defined(__SSE2__)
    for (; xv + 8 <= x_hi; xv += 8) decimate8(t, xv, o);
#endif
    for (int x = xv; x < x_hi; ++x) {
      const int sx = 2 * x;
      const std::uint16_t acc = static_cast<std::uint16_t>(t[sx - 2] + 4 * t[sx - 1] + 6 * t[sx] + 4 * t[sx + 1] + t[sx + 2] + 128);
      o[x] = static_cast<std::uint8_t>(acc >> 8);
    }
    for (int x = x_hi; x < dst.width; ++x) clamped(x);
  }
}

}  // namespace

Status ImagePyramid::build(const ImageView& image) {
  const ImageView& l0 = views_[0];
  if (!image.valid() || image.width != l0.width || image.height != l0.height) return Status::kInvalidInput;
  ++generation_;
  auto* dst = const_cast<std::uint8_t*>(l0.data);
  if (image.stride == l0.width) {
    std::memcpy(dst, image.data, static_cast<std::size_t>(l0.width) * static_cast<std::size_t>(l0.height));
  } else {
    for (int y = 0; y < l0.height; ++y) std::memcpy(dst + static_cast<long>(y) * l0.stride, image.row(y), static_cast<std::size_t>(l0.width));
  }
  for (int l = 1; l < levels_; ++l) downsample(views_[l - 1], views_[l], row_tmp_.data());
  return Status::kOk;
}

}  // namespace ums
