#include "core/frontend/corner_detector.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "core/frontend/float_lanes.hpp"
#include "core/frontend/klt_tracker.hpp"
#include "core/frontend/pixel_disk.hpp"

#if defined(__ARM_NEON)
#include <arm_neon.h>
#elif defined(__AVX2__)
#include <immintrin.h>
#elif defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace ums {

void DetectorOptions::validate() const {
  auto fail = [](const char* field, double v) {
    throw std::invalid_argument(std::string("DetectorOptions.") + field + " out of range: " + std::to_string(v));
  };
  if (!(quality_level > 0.0f && quality_level < 1.0f)) fail("quality_level", static_cast<double>(quality_level));
  if (!(min_response >= 0.0f)) fail("min_response", static_cast<double>(min_response));
  if (!(min_distance_px >= 1.0f && min_distance_px <= 200.0f)) fail("min_distance_px", static_cast<double>(min_distance_px));
  if (border_px < 2) fail("border_px", border_px);
  if (subpix_half_window < 1 || subpix_half_window > CornerDetector::kMaxSubpixHalfWindow) fail("subpix_half_window", subpix_half_window);
  if (subpix_half_window + 2 > border_px) fail("subpix_half_window (must be <= border_px - 2)", subpix_half_window);
  if (subpix_max_iterations < 0) fail("subpix_max_iterations", subpix_max_iterations);
  if (!(subpix_epsilon_px > 0.0f)) fail("subpix_epsilon_px", static_cast<double>(subpix_epsilon_px));
}

CornerDetector::CornerDetector(int width, int height) : width_(width), height_(height) {
  if (width < 8 || height < 8 || width > capacity::kMaxImageWidth || height > capacity::kMaxImageHeight) {
    throw std::runtime_error("CornerDetector: image size " + std::to_string(width) + "x" + std::to_string(height) +
                             " outside capacity");
  }
  const std::size_t n = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  response_.assign(n, 0.0f);
  rows_.assign(static_cast<std::size_t>(12 * width), 0.0f);
  mask_.assign(n, 0);
  need_.assign(static_cast<std::size_t>(height) * kGroupWords, 0ULL);
  scratch_.assign(static_cast<std::size_t>(height) * kGroupWords, 0ULL);
  heap_.reserve(capacity::kMaxCornerCandidates);
}

void CornerDetector::clear_mask() { std::memset(mask_.data(), 0, mask_.size()); }

void CornerDetector::block_disk(const Eigen::Vector2f& c, float r) {
  if (!std::isfinite(c.x()) || !std::isfinite(c.y())) return;
  const int y_lo = std::max(0, disk_first_row(c, r));
  const int y_hi = std::min(height_ - 1, disk_last_row(c, r));
  for (int y = y_lo; y <= y_hi; ++y) {
    int x_lo = 0, x_hi = 0;
    disk_row_span(c, r, y, &x_lo, &x_hi);
    x_lo = std::max(0, x_lo);
    x_hi = std::min(width_ - 1, x_hi);
    if (x_hi >= x_lo) std::memset(mask_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(width_) + x_lo, 1, static_cast<std::size_t>(x_hi - x_lo + 1));
  }
}

bool CornerDetector::is_free(const Eigen::Vector2f& p) const {
  const int x = static_cast<int>(std::lround(p.x())), y = static_cast<int>(std::lround(p.y()));
  if (x < 0 || y < 0 || x >= width_ || y >= height_) return false;
  return mask_[static_cast<std::size_t>(y) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(x)] == 0;
}

namespace {

// True when one of the 8 mask bytes at p is 0 (free): mask bytes are 0 or 1 (block_disk), so
// the 8 are all blocked exactly when they read as 0x0101010101010101.
bool has_free_byte(const std::uint8_t* p) {
  std::uint64_t v;
  std::memcpy(&v, p, sizeof v);
  return v != 0x0101010101010101ULL;
}

// The response's kernels in 4- and 8-lane vectors (GCC vector extensions: SSE2 on x86-64, NEON
// on aarch64), each followed by the scalar formula for the row's last pixels. Every lane does
// the scalar formula's operations in its order (integer Sobel, exact float products and sums,
// then the rounded eigenvalue; no contraction), so the vector and scalar pixels, and every
// machine, give the same bits.
using F4 = FloatLanes;
typedef short S8 __attribute__((vector_size(16)));
// 8 pixels widened to 16-bit lanes, and a half of 8 such lanes as floats (exact). The widenings
// are the targets' own instructions: GCC's generic conversions build them lane by lane.
inline S8 load8_u8(const std::uint8_t* p) {
#if defined(__ARM_NEON)
  return vreinterpretq_s16_u16(vmovl_u8(vld1_u8(p)));
#elif defined(__SSE2__)
  return (S8)_mm_unpacklo_epi8(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)), _mm_setzero_si128());
#else
  S8 v;
  for (int k = 0; k < 8; ++k) v[k] = p[k];
  return v;
#endif
}
template <int kHalf>
inline F4 half_to_float(S8 v) {
#if defined(__ARM_NEON)
  return vcvtq_f32_s32(vmovl_s16(kHalf == 0 ? vget_low_s16(v) : vget_high_s16(v)));
#elif defined(__SSE2__)
  const __m128i w = (__m128i)v;
  const __m128i wide = kHalf == 0 ? _mm_unpacklo_epi16(w, w) : _mm_unpackhi_epi16(w, w);
  return _mm_cvtepi32_ps(_mm_srai_epi32(wide, 16));  // the sign-extended lanes
#else
  return F4{static_cast<float>(v[4 * kHalf]), static_cast<float>(v[4 * kHalf + 1]), static_cast<float>(v[4 * kHalf + 2]),
            static_cast<float>(v[4 * kHalf + 3])};
#endif
}
inline F4 sqrt4(F4 v) {
#if defined(__ARM_NEON) && defined(__aarch64__)  // ARMv7 NEON has no vector square root
  return vsqrtq_f32(v);
#elif defined(__SSE2__)
  return _mm_sqrt_ps(v);
#else
  for (int k = 0; k < 4; ++k) v[k] = std::sqrt(v[k]);
  return v;
#endif
}

#if defined(__AVX2__)
// The x86-64-v3 host build (cmake/UmsHostIsa.cmake): the same per-pixel formulas on 8 float
// lanes (16 integer lanes for the Sobel sums), then the 4-lane kernels for a run's rest. Pixels
// are independent, so the lane count changes no bit.
typedef float F8 __attribute__((vector_size(32)));
typedef short S16 __attribute__((vector_size(32)));
inline F8 load8_lanes(const float* p) {
  F8 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline void store8_lanes(float* p, F8 v) { std::memcpy(p, &v, sizeof v); }
inline S16 load16_u8(const std::uint8_t* p) {
  return (S16)_mm256_cvtepu8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
}
template <int kHalf>
inline F8 half16_to_float(S16 v) {
  const __m128i half = _mm256_extracti128_si256((__m256i)v, kHalf);
  return _mm256_cvtepi32_ps(_mm256_cvtepi16_epi32(half));
}
#endif

// Calls step(x) for x = x0, x0 + kStep, ... while kStep pixels fit in [x0, x1), then, in a run
// of kStep pixels or more, once more on its last kStep: that step overlaps the one before, whose
// pixels it writes again with the same values (or takes their maximum again), instead of a scalar
// loop over the last few. Returns the first pixel left to a scalar loop (x1 when none).
template <int kStep, class Step>
inline int vector_steps(int x0, int x1, Step&& step) {
  int x = x0;
#pragma GCC unroll 4
  for (; x + kStep <= x1; x += kStep) step(x);
  if (x < x1 && x1 - x0 >= kStep) {
    step(x1 - kStep);
    return x1;
  }
  return x;
}

// Sobel gradients of row r1 (r0 above, r2 below) and their products, x in x0 .. x1-1 (x0 >= 1,
// x1 <= width - 1): 8 pixels per step, on 16-bit lanes (|dx|, |dy| <= 4 * 255).
void sobel_products(const std::uint8_t* __restrict r0, const std::uint8_t* __restrict r1,
                    const std::uint8_t* __restrict r2, int x0, int x1, float* __restrict xx, float* __restrict xy,
                    float* __restrict yy) {
  auto step8 = [&](int x) {  // reads up to x + 8 <= width - 1
    const S8 a0 = load8_u8(r0 + x - 1), a1 = load8_u8(r0 + x), a2 = load8_u8(r0 + x + 1);
    const S8 b0 = load8_u8(r1 + x - 1), b2 = load8_u8(r1 + x + 1);
    const S8 c0 = load8_u8(r2 + x - 1), c1 = load8_u8(r2 + x), c2 = load8_u8(r2 + x + 1);
    const S8 dx = (a2 - a0) + 2 * (b2 - b0) + (c2 - c0);
    const S8 dy = (c0 - a0) + 2 * (c1 - a1) + (c2 - a2);
    const F4 fx[2] = {half_to_float<0>(dx), half_to_float<1>(dx)};
    const F4 fy[2] = {half_to_float<0>(dy), half_to_float<1>(dy)};
    for (int h = 0; h < 2; ++h) {
      store_lanes(xx + x + 4 * h, fx[h] * fx[h]);
      store_lanes(xy + x + 4 * h, fx[h] * fy[h]);
      store_lanes(yy + x + 4 * h, fy[h] * fy[h]);
    }
  };
  int x_rest = x0;
#if defined(__AVX2__)
  auto step16 = [&](int x) {  // reads up to x + 16 <= width - 1
    const S16 a0 = load16_u8(r0 + x - 1), a1 = load16_u8(r0 + x), a2 = load16_u8(r0 + x + 1);
    const S16 b0 = load16_u8(r1 + x - 1), b2 = load16_u8(r1 + x + 1);
    const S16 c0 = load16_u8(r2 + x - 1), c1 = load16_u8(r2 + x), c2 = load16_u8(r2 + x + 1);
    const S16 dx = (a2 - a0) + 2 * (b2 - b0) + (c2 - c0);
    const S16 dy = (c0 - a0) + 2 * (c1 - a1) + (c2 - a2);
    const F8 fx[2] = {half16_to_float<0>(dx), half16_to_float<1>(dx)};
    const F8 fy[2] = {half16_to_float<0>(dy), half16_to_float<1>(dy)};
    for (int h = 0; h < 2; ++h) {
      store8_lanes(xx + x + 8 * h, fx[h] * fx[h]);
      store8_lanes(xy + x + 8 * h, fx[h] * fy[h]);
      store8_lanes(yy + x + 8 * h, fy[h] * fy[h]);
    }
  };
  x_rest = vector_steps<16>(x_rest, x1, step16);
#endif
  for (int x = vector_steps<8>(x_rest, x1, step8); x < x1; ++x) {
    const int dx = (r0[x + 1] - r0[x - 1]) + 2 * (r1[x + 1] - r1[x - 1]) + (r2[x + 1] - r2[x - 1]);
    const int dy = (r2[x - 1] - r0[x - 1]) + 2 * (r2[x] - r0[x]) + (r2[x + 1] - r0[x + 1]);
    const float fdx = static_cast<float>(dx), fdy = static_cast<float>(dy);
    xx[x] = fdx * fdx;
    xy[x] = fdx * fdy;
    yy[x] = fdy * fdy;
  }
}

// out[x] = a[x] + b[x] + c[x] for x in x0 .. x1-1.
void sum3_rows(const float* __restrict a, const float* __restrict b, const float* __restrict c, float* __restrict out,
               int x0, int x1) {
  int x_rest = x0;
#if defined(__AVX2__)
  auto step8 = [&](int x) { store8_lanes(out + x, load8_lanes(a + x) + load8_lanes(b + x) + load8_lanes(c + x)); };
  x_rest = vector_steps<8>(x_rest, x1, step8);
#endif
  auto step4 = [&](int x) { store_lanes(out + x, load_lanes(a + x) + load_lanes(b + x) + load_lanes(c + x)); };
  for (int x = vector_steps<4>(x_rest, x1, step4); x < x1; ++x) out[x] = a[x] + b[x] + c[x];
}

// The smaller eigenvalue of the 3x3-summed tensor from the vertical sums va, vb, vc (Ixx, Ixy,
// Iyy), x in x0 .. x1-1 (x0 >= 1, x1 <= width - 1).
void shi_tomasi_row(const float* __restrict va, const float* __restrict vb, const float* __restrict vc, float norm,
                    int x0, int x1, float* __restrict out) {
  auto step4 = [&](int x) {
    const F4 sa = (load_lanes(va + x - 1) + load_lanes(va + x) + load_lanes(va + x + 1)) * norm;
    const F4 sb = (load_lanes(vb + x - 1) + load_lanes(vb + x) + load_lanes(vb + x + 1)) * norm;
    const F4 sc = (load_lanes(vc + x - 1) + load_lanes(vc + x) + load_lanes(vc + x + 1)) * norm;
    store_lanes(out + x, 0.5f * ((sa + sc) - sqrt4((sa - sc) * (sa - sc) + 4.0f * sb * sb)));
  };
  int x_rest = x0;
#if defined(__AVX2__)
  auto step8 = [&](int x) {
    const F8 sa = (load8_lanes(va + x - 1) + load8_lanes(va + x) + load8_lanes(va + x + 1)) * norm;
    const F8 sb = (load8_lanes(vb + x - 1) + load8_lanes(vb + x) + load8_lanes(vb + x + 1)) * norm;
    const F8 sc = (load8_lanes(vc + x - 1) + load8_lanes(vc + x) + load8_lanes(vc + x + 1)) * norm;
    store8_lanes(out + x, 0.5f * ((sa + sc) - (F8)_mm256_sqrt_ps((__m256)((sa - sc) * (sa - sc) + 4.0f * sb * sb))));
  };
  x_rest = vector_steps<8>(x_rest, x1, step8);
#endif
  for (int x = vector_steps<4>(x_rest, x1, step4); x < x1; ++x) {
    const float sa = (va[x - 1] + va[x] + va[x + 1]) * norm;
    const float sb = (vb[x - 1] + vb[x] + vb[x + 1]) * norm;
    const float sc = (vc[x - 1] + vc[x] + vc[x + 1]) * norm;
    out[x] = 0.5f * ((sa + sc) - std::sqrt((sa - sc) * (sa - sc) + 4.0f * sb * sb));
  }
}

// max(lanes, out[x] at pixels with m[x] == 0) over x in x0 .. x1-1, 4 pixels at once (the
// busy ones as 0, the neutral start: responses are >= 0); a run's last pixels are its last 4
// again (a maximum is exact in any order and with repeats).
void masked_max(const float* __restrict out, const std::uint8_t* __restrict m, int x0, int x1, F4* lanes) {
  typedef int I4 __attribute__((vector_size(16)));
  F4 mx = *lanes;
  auto step4 = [&](int x) {
    std::uint32_t four;
    std::memcpy(&four, m + x, sizeof four);
    if (four == 0x01010101u) return;  // mask bytes are 0 or 1 (block_disk)
    F4 v = load_lanes(out + x);
    if (four != 0) {
      const I4 busy = {m[x], m[x + 1], m[x + 2], m[x + 3]};
      v = busy == 0 ? v : F4{0.0f, 0.0f, 0.0f, 0.0f};
    }
    mx = v > mx ? v : mx;
  };
  for (int x = vector_steps<4>(x0, x1, step4); x < x1; ++x) mx[0] = std::max(mx[0], m[x] == 0 ? out[x] : 0.0f);
  *lanes = mx;
}

// Bit k set: mask byte p[k] is 0 (free). Mask bytes are 0 or 1 (block_disk), so the product
// gathers the four bytes' lowest bits into the top byte without carries.
inline unsigned free_lanes4(const std::uint8_t* p) {
  std::uint32_t four;
  std::memcpy(&four, p, sizeof four);
  if (four == 0x01010101u) return 0;
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
  return ~((four * 0x01020408u) >> 24) & 0xFu;
#else
  return (p[0] == 0 ? 1u : 0u) | (p[1] == 0 ? 2u : 0u) | (p[2] == 0 ? 4u : 0u) | (p[3] == 0 ? 8u : 0u);
#endif
}

// Bit k set: the response r0[k] (rm: the row above, rp: below) is at or above thresh and a 3x3
// maximum, ties going to the first pixel in scan order: the scalar test of each pixel, lane by
// lane (a NaN fails it in both).
// Responses are finite (sums of integers, then a root of a sum of squares), so v > each of
// three values exactly when v > their maximum: one comparison per neighbour row.
inline F4 max2(F4 a, F4 b) {
#if defined(__SSE2__)
  return _mm_max_ps(a, b);
#elif defined(__ARM_NEON)
  return vmaxq_f32(a, b);
#else
  return a > b ? a : b;
#endif
}
inline F4 max3(const float* r) { return max2(max2(load_lanes(r - 1), load_lanes(r)), load_lanes(r + 1)); }
inline unsigned maxima4(const float* rm, const float* r0, const float* rp, float thresh) {
  typedef int I4 __attribute__((vector_size(16)));
  const F4 v = load_lanes(r0);
  const I4 ok = (v >= thresh) & (v > max3(rm)) & (v > load_lanes(r0 - 1)) & (v >= load_lanes(r0 + 1)) & (v >= max3(rp));
#if defined(__SSE2__)
  return static_cast<unsigned>(_mm_movemask_ps(reinterpret_cast<__m128>(ok)));
#elif defined(__ARM_NEON) && defined(__aarch64__)
  const uint32x4_t weights = {1u, 2u, 4u, 8u};
  return vaddvq_u32(vandq_u32(vreinterpretq_u32_s32(ok), weights));
#else
  return (ok[0] != 0 ? 1u : 0u) | (ok[1] != 0 ? 2u : 0u) | (ok[2] != 0 ? 4u : 0u) | (ok[3] != 0 ? 8u : 0u);
#endif
}

// out = a | b | c, rows of column-group bits.
void or3(const std::uint64_t* a, const std::uint64_t* b, const std::uint64_t* c, std::uint64_t* out) {
  for (int i = 0; i < CornerDetector::kGroupWords; ++i) out[i] = a[i] | b[i] | c[i];
}

// Calls f(x0, x1) for each run of set group bits as a pixel range grown by pad pixels to each
// side and clipped to [lo, hi) (padded runs may overlap: the pixels between are done twice).
template <class F>
void for_each_run(const std::uint64_t* bits, int pad, int lo, int hi, F&& f) {
  constexpr int kWords = CornerDetector::kGroupWords, kG = CornerDetector::kGroupPx;
  int wi = 0;
  std::uint64_t cur = bits[0];
  for (;;) {
    while (cur == 0) {
      if (++wi >= kWords) return;
      cur = bits[wi];
    }
    const int g0 = wi * 64 + __builtin_ctzll(cur);
    // The run ends at the first clear bit at or after g0.
    std::uint64_t clear = ~bits[wi] & (~0ULL << (g0 & 63));
    while (clear == 0 && wi + 1 < kWords) clear = ~bits[++wi];
    const int g1 = clear == 0 ? kWords * 64 : wi * 64 + __builtin_ctzll(clear);
    const int x0 = std::max(lo, g0 * kG - pad), x1 = std::min(hi, g1 * kG + pad);
    if (x0 < x1) f(x0, x1);
    if (g1 >= kWords * 64 || x1 >= hi) return;
    wi = g1 >> 6;
    cur = bits[wi] & (~0ULL << (g1 & 63));
  }
}

}  // namespace

// Groups of kGroupPx columns holding a free pixel inside the border b, per row; then need_, the
// groups with a free pixel in the row or the rows above and below: a free pixel's 3x3 maximum
// test reads the response there and one pixel to either side of them.
void CornerDetector::mark_needed_groups(int b) {
  const int w = width_, h = height_;
  std::uint64_t* free_rows = scratch_.data();  // h rows of kGroupWords
  std::fill(scratch_.begin(), scratch_.end(), 0ULL);
  // Groups wholly inside [b, w - b) test their 8 mask bytes at once; the (at most two) cut by
  // the border test the bytes inside it.
  const int g_first = (b + kGroupPx - 1) / kGroupPx, g_end = (w - b) / kGroupPx;
  for (int y = b; y < h - b; ++y) {
    const std::uint8_t* m = mask_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(w);
    std::uint64_t* bits = free_rows + static_cast<std::size_t>(y) * kGroupWords;
    auto mark_cut = [&](int g) {
      bool any = false;
      for (int x = std::max(g * kGroupPx, b); x < std::min(g * kGroupPx + kGroupPx, w - b); ++x) any |= m[x] == 0;
      bits[g >> 6] |= static_cast<std::uint64_t>(any) << (g & 63);
    };
    if (b % kGroupPx != 0) mark_cut(b / kGroupPx);
    // Each word's bits gathered in a register: a store through bits[] would be reloaded after
    // every mask byte read (a byte pointer may alias it).
    for (int g = g_first; g < g_end;) {
      const int word_end = std::min(g_end, (g / 64 + 1) * 64);
      std::uint64_t word = 0;
      for (; g < word_end; ++g) word |= static_cast<std::uint64_t>(has_free_byte(m + g * kGroupPx)) << (g & 63);
      bits[(g - 1) >> 6] |= word;
    }
    if ((w - b) % kGroupPx != 0) mark_cut(g_end);
  }
  std::fill(need_.begin(), need_.end(), 0ULL);
  auto row = [&](int y) { return free_rows + static_cast<std::size_t>(y) * kGroupWords; };
  for (int y = b - 1; y < h - b + 1; ++y) or3(row(y - 1), row(y), row(y + 1), need_.data() + static_cast<std::size_t>(y) * kGroupWords);
}

// Rolling computation over the groups in need_ (and one pixel to either side) only: the Sobel
// products of row y go into ring slot y % 3; the response of row y - 1 is the 3x3 box sum over
// slots (y-2, y-1, y), taken separably (vertical 3-row sum, then a horizontal 3-sum). Products and
// vertical sums are formed one more pixel to either side, products for every row the sums read. Every product is an integer of at most
// (4 * 255)^2 and nine of them stay below 2^24, so all these float sums are exact and equal in any
// order: the separable form gives the same bits as the direct 3x3 sum. Returns the largest response
// at a free pixel inside the border b (OpenCV's goodFeaturesToTrack: the maximum under the mask).
float CornerDetector::compute_response(const ImageView& img, int b) {
  const int w = width_, h = height_;
  const float kNorm = 1.0f / (8.0f * 8.0f * 9.0f);  // Sobel gain 8 per gradient, 9-pixel block mean
  float* base = rows_.data();
  auto slot = [&](int y, int which) { return base + static_cast<std::size_t>(((y % 3) * 3 + which) * w); };
  auto need = [&](int y) { return need_.data() + static_cast<std::size_t>(y) * kGroupWords; };
  float* va = base + static_cast<std::size_t>(9 * w);  // vertical sums of the three products
  const float* vb = va + w;
  const float* vc = vb + w;
  F4 lanes = {0.0f, 0.0f, 0.0f, 0.0f};  // responses are >= 0: 0 is the neutral start
  for (int y = 1; y < h - 1; ++y) {
    std::uint64_t prod[kGroupWords];
    or3(need(y - 1), need(y), need(y + 1), prod);
    for_each_run(prod, 2, 1, w - 1, [&](int x0, int x1) {
      sobel_products(img.row(y - 1), img.row(y), img.row(y + 1), x0, x1, slot(y, 0), slot(y, 1), slot(y, 2));
    });
    if (y < 3) continue;
    const int yc = y - 1;  // rows yc-1, yc, yc+1 = y-2, y-1, y are all in the ring
    for_each_run(need(yc), 2, 1, w - 1, [&](int x0, int x1) {
      for (int k = 0; k < 3; ++k) sum3_rows(slot(y - 2, k), slot(y - 1, k), slot(y, k), va + k * w, x0, x1);
    });
    float* out = response_.data() + static_cast<std::size_t>(yc) * static_cast<std::size_t>(w);
    const std::uint8_t* m = mask_.data() + static_cast<std::size_t>(yc) * static_cast<std::size_t>(w);
    const bool in_border = yc >= b && yc < h - b;
    for_each_run(need(yc), 1, 2, w - 2, [&](int x0, int x1) {
      shi_tomasi_row(va, vb, vc, kNorm, x0, x1, out);
      if (in_border) masked_max(out, m, std::max(x0, b), std::min(x1, w - b), &lanes);
    });
  }
  float max_r = 0.0f;
  for (int k = 0; k < 4; ++k) max_r = std::max(max_r, lanes[k]);
  return max_r;
}

float CornerDetector::response(int x, int y) const {
  if (x < 2 || y < 2 || x >= width_ - 2 || y >= height_ - 2) return 0.0f;
  const std::uint64_t* bits = need_.data() + static_cast<std::size_t>(y) * kGroupWords;
  bool computed = false;  // its group or the group one pixel to either side is needed
  for (int dx = -1; dx <= 1; ++dx) {
    const int g = (x + dx) / kGroupPx;
    computed |= ((bits[g >> 6] >> (g & 63)) & 1ULL) != 0;
  }
  return computed ? response_[static_cast<std::size_t>(y) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(x)]
                  : std::numeric_limits<float>::quiet_NaN();
}

// The strongest kMaxCornerCandidates candidates stay. Until the store is full they are only
// appended: the selection orders them by a strict total order (RanksBelow), so their arrangement
// does not matter, and a detection rarely finds that many. When it fills, it becomes the min-heap
// by score that pushing each one in turn would have built (the same pushes, later), so the
// candidates evicted after that are the ones the heap always evicted, ties included.
void CornerDetector::offer(const Candidate& c) {
  if (heap_.size() < capacity::kMaxCornerCandidates) {
    heap_.push_back(c);  // within reserved capacity: no allocation
    if (heap_.size() == capacity::kMaxCornerCandidates)
      for (auto end = heap_.begin() + 2; end <= heap_.end(); ++end) std::push_heap(heap_.begin(), end, ScoresGreater{});
  } else if (c.score > heap_.front().score) {
    std::pop_heap(heap_.begin(), heap_.end(), ScoresGreater{});
    heap_.back() = c;
    std::push_heap(heap_.begin(), heap_.end(), ScoresGreater{});
  }
}

// Row y's candidates: free, at or above thresh and a 3x3 maximum, ties going to the first pixel
// in scan order; they enter the heap in scan order. Most of the image is covered by the disks
// around the features already tracked: only the runs of column groups mark_needed_groups found a
// free pixel in (scratch_) are visited, 4 pixels at once (maxima4) and the free ones among those
// passing; a run's last pixels one by one.
void CornerDetector::offer_row_maxima(int y, int b, float thresh) {
  const int w = width_;
  const float* rm = response_.data() + static_cast<std::size_t>(y - 1) * static_cast<std::size_t>(w);
  const float* r0 = rm + w;
  const float* rp = r0 + w;
  const std::uint8_t* m = mask_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(w);
  const std::uint64_t* groups = scratch_.data() + static_cast<std::size_t>(y) * kGroupWords;
  for_each_run(groups, 0, b, w - b, [&](int x0, int x1) {
    int x = x0;
    for (; x + 4 <= x1; x += 4) {  // reads up to r0[x + 4] <= r0[w - b + 3]: inside the row (b >= 3)
      const unsigned free = free_lanes4(m + x);
      if (free == 0) continue;
      for (unsigned lanes = free & maxima4(rm + x, r0 + x, rp + x, thresh); lanes != 0; lanes &= lanes - 1) {
        const int k = __builtin_ctz(lanes);
        offer(Candidate{r0[x + k], x + k, y});
      }
    }
    for (; x < x1; ++x) {
      const float v = r0[x];
      if (m[x] == 0 && v >= thresh && v > rm[x - 1] && v > rm[x] && v > rm[x + 1] && v > r0[x - 1] &&
          v >= r0[x + 1] && v >= rp[x - 1] && v >= rp[x] && v >= rp[x + 1])
        offer(Candidate{v, x, y});
    }
  });
}

int CornerDetector::detect(const ImageView& image, int max_new, const DetectorOptions& options, Eigen::Vector2f* out_px) {
  if (max_new <= 0 || !image.valid() || image.width != width_ || image.height != height_) return 0;
  const int h = height_;
  const int b = std::max(options.border_px, 3);
  mark_needed_groups(b);
  const float max_r = compute_response(image, b);
  const float thresh = std::max(options.min_response, options.quality_level * max_r);
  heap_.clear();
  for (int y = b; y < h - b; ++y) offer_row_maxima(y, b, thresh);
  // Strongest first, equal scores in scan order. A detection places a few corners among thousands
  // of maxima, so the candidates leave a max-heap one at a time instead of being sorted.
  std::make_heap(heap_.begin(), heap_.end(), RanksBelow{});
  auto end = heap_.end();
  int count = 0;
  while (count < max_new && end != heap_.begin()) {
    std::pop_heap(heap_.begin(), end, RanksBelow{});
    const Candidate& c = *--end;
    Eigen::Vector2f p(static_cast<float>(c.x), static_cast<float>(c.y));
    if (!is_free(p)) continue;
    refine_subpixel(image, options, &p);  // keeps the integer position when it fails
    if (!is_free(p)) continue;             // refinement moved it next to an accepted corner
    out_px[count++] = p;
    block_disk(p, options.min_distance_px);
  }
  return count;
}

bool CornerDetector::refine_subpixel(const ImageView& image, const DetectorOptions& options, Eigen::Vector2f* p) {
  constexpr int kMaxN = 2 * kMaxSubpixHalfWindow + 1;
  constexpr int kMaxE = kMaxN + 2;
  float patch[kMaxE * kMaxE];
  const int hw = options.subpix_half_window;
  const int n = 2 * hw + 1, ne = n + 2;
  // Gaussian weights favour the centre, as gradients far out belong to other structures.
  float wgt[kMaxN];
  const float sigma = 0.5f * static_cast<float>(hw) + 0.5f;
  for (int i = 0; i < n; ++i) {
    const float d = static_cast<float>(i - hw);
    wgt[i] = std::exp(-0.5f * d * d / (sigma * sigma));
  }
  const Eigen::Vector2f start = *p;
  Eigen::Vector2f q = start;
  for (int it = 0; it < options.subpix_max_iterations; ++it) {
    sample_patch_bilinear(image, q.x() - static_cast<float>(hw + 1), q.y() - static_cast<float>(hw + 1), ne, patch);
    float a = 0.0f, bb = 0.0f, c = 0.0f, bx = 0.0f, by = 0.0f;
    for (int j = 0; j < n; ++j) {
      const float* row = patch + (j + 1) * ne + 1;
      const float oy = static_cast<float>(j - hw);
      for (int i = 0; i < n; ++i) {
        const float gx = 0.5f * (row[i + 1] - row[i - 1]);
        const float gy = 0.5f * (row[i + ne] - row[i - ne]);
        const float ww = wgt[i] * wgt[j];
        const float gxx = ww * gx * gx, gxy = ww * gx * gy, gyy = ww * gy * gy;
        const float ox = static_cast<float>(i - hw);
        a += gxx;
        bb += gxy;
        c += gyy;
        // Offsets relative to q keep the sums well conditioned.
        bx += gxx * ox + gxy * oy;
        by += gxy * ox + gyy * oy;
      }
    }
    const float det = a * c - bb * bb;
    if (!(det > 1e-6f * (a + c) * (a + c)) || !(det > 0.0f)) return false;
    const float dx = (c * bx - bb * by) / det;
    const float dy = (a * by - bb * bx) / det;
    q.x() += dx;
    q.y() += dy;
    if ((q - start).cwiseAbs().maxCoeff() > static_cast<float>(hw)) return false;
    if (dx * dx + dy * dy < options.subpix_epsilon_px * options.subpix_epsilon_px) break;
  }
  if (!std::isfinite(q.x()) || !std::isfinite(q.y())) return false;
  *p = q;
  return true;
}

}  // namespace ums
