#include "core/frontend/klt_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "core/frontend/float_lanes.hpp"

#if defined(__AVX2__)
#include <immintrin.h>
#elif defined(__SSE2__)
#include <emmintrin.h>
#elif defined(__ARM_NEON)
#include <arm_neon.h>
#endif

namespace ums {

namespace {

// A window's samples are integers: 128 x grey levels (0 .. 32640), and a template gradient is
// kept as the central difference of two samples (twice the gradient, -32640 .. 32640), so both
// fit 16-bit lanes, 8 to a vector. The window sums are exact integer sums (a product of two is
// below 2^30, a sum of two products below 2^31, a window's sum below 2^48): every order, lane
// split and machine gives the same integers, then one rounding to float.
using Px = std::int16_t;
constexpr int kPxLanes = 8;

#if defined(__ARM_NEON)
inline int16x8_t load_px(const Px* p) { return vld1q_s16(p); }
// acc += the products of a and b: two products in each 32-bit lane (their sum below 2^31, as
// pmaddwd's on SSE2), then widened (vpadal: pairwise add-accumulate long).
inline int64x2_t add_products(int64x2_t acc, int16x8_t a, int16x8_t b) {
  const int32x4_t p = vmlal_s16(vmull_s16(vget_low_s16(a), vget_low_s16(b)), vget_high_s16(a), vget_high_s16(b));
  return vpadalq_s32(acc, p);
}
// acc += the values of a (pairwise add-accumulate long: a window's sum stays below 2^23).
inline int32x4_t add_values(int32x4_t acc, int16x8_t a) { return vpadalq_s16(acc, a); }
inline std::int64_t total64(int64x2_t v) { return vgetq_lane_s64(v, 0) + vgetq_lane_s64(v, 1); }
inline std::int64_t total32(int32x4_t v) {
  return static_cast<std::int64_t>(vgetq_lane_s32(v, 0)) + vgetq_lane_s32(v, 1) + vgetq_lane_s32(v, 2) + vgetq_lane_s32(v, 3);
}
#elif defined(__SSE2__)
inline __m128i load_px(const Px* p) { return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p)); }
// acc (two 64-bit lanes) += the products of a and b: pmaddwd's four sums of two products, sign
// extended.
inline __m128i add_products(__m128i acc, __m128i a, __m128i b) {
  const __m128i p = _mm_madd_epi16(a, b);
  const __m128i sign = _mm_srai_epi32(p, 31);
  acc = _mm_add_epi64(acc, _mm_unpacklo_epi32(p, sign));
  return _mm_add_epi64(acc, _mm_unpackhi_epi32(p, sign));
}
// acc (four 32-bit lanes) += the values of a, in pairs.
inline __m128i add_values(__m128i acc, __m128i a) { return _mm_add_epi32(acc, _mm_madd_epi16(a, _mm_set1_epi16(1))); }
inline std::int64_t total64(__m128i v) {
  alignas(16) std::int64_t l[2];
  _mm_store_si128(reinterpret_cast<__m128i*>(l), v);
  return l[0] + l[1];
}
inline std::int64_t total32(__m128i v) {
  alignas(16) std::int32_t l[4];
  _mm_store_si128(reinterpret_cast<__m128i*>(l), v);
  return static_cast<std::int64_t>(l[0]) + l[1] + l[2] + l[3];
}
#endif

#if defined(__AVX2__)
// The x86-64-v3 host build (cmake/UmsHostIsa.cmake): the same exact integer sums on 16 lanes
// (the 8-lane SSE2 step takes a window's last 8).
constexpr int kPxLanes16 = 16;
inline __m256i load_px16(const Px* p) { return _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p)); }
inline __m256i add_products(__m256i acc, __m256i a, __m256i b) {
  const __m256i p = _mm256_madd_epi16(a, b);
  acc = _mm256_add_epi64(acc, _mm256_cvtepi32_epi64(_mm256_castsi256_si128(p)));
  return _mm256_add_epi64(acc, _mm256_cvtepi32_epi64(_mm256_extracti128_si256(p, 1)));
}
inline __m256i add_values(__m256i acc, __m256i a) {
  return _mm256_add_epi32(acc, _mm256_madd_epi16(a, _mm256_set1_epi16(1)));
}
inline std::int64_t total64(__m256i v) {
  return total64(_mm_add_epi64(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1)));
}
inline std::int64_t total32(__m256i v) {
  return total32(_mm256_castsi256_si128(v)) + total32(_mm256_extracti128_si256(v, 1));
}
#endif

// The vector types and the few operations the window sums need beyond the overloads above, per
// instruction set: kN elements per step.
#if defined(__ARM_NEON)
struct PxLanes {
  static constexpr int kN = kPxLanes;
  using Acc64 = int64x2_t;
  using Acc32 = int32x4_t;
  static int16x8_t load(const Px* p) { return load_px(p); }
  static int16x8_t sub(int16x8_t a, int16x8_t b) { return vsubq_s16(a, b); }
  static Acc64 zero64() { return vdupq_n_s64(0); }
  static Acc32 zero32() { return vdupq_n_s32(0); }
};
#elif defined(__SSE2__)
struct PxLanes {
  static constexpr int kN = kPxLanes;
  using Acc64 = __m128i;
  using Acc32 = __m128i;
  static __m128i load(const Px* p) { return load_px(p); }
  static __m128i sub(__m128i a, __m128i b) { return _mm_sub_epi16(a, b); }
  static __m128i zero64() { return _mm_setzero_si128(); }
  static __m128i zero32() { return _mm_setzero_si128(); }
};
#endif
#if defined(__AVX2__)
struct PxLanes16 {
  static constexpr int kN = kPxLanes16;
  using Acc64 = __m256i;
  using Acc32 = __m256i;
  static __m256i load(const Px* p) { return load_px16(p); }
  static __m256i sub(__m256i a, __m256i b) { return _mm256_sub_epi16(a, b); }
  static __m256i zero64() { return _mm256_setzero_si256(); }
  static __m256i zero32() { return _mm256_setzero_si256(); }
};
#endif

#if defined(__ARM_NEON) || defined(__SSE2__)
// s[0..5) += sum gx gx, gx gy, gy gy, gx, gy over elements k, k + 1, ... in whole steps of L::kN;
// returns the first element left.
template <class L>
__attribute__((always_inline)) inline int add_gradient_lanes(const Px* gx, const Px* gy, int nn, int k,
                                                              std::int64_t* s) {
  typename L::Acc64 axx = L::zero64(), axy = axx, ayy = axx;
  typename L::Acc32 ax = L::zero32(), ay = ax;
  for (; k + L::kN <= nn; k += L::kN) {
    const auto a = L::load(gx + k), b = L::load(gy + k);
    axx = add_products(axx, a, a);
    axy = add_products(axy, a, b);
    ayy = add_products(ayy, b, b);
    ax = add_values(ax, a);
    ay = add_values(ay, b);
  }
  s[0] += total64(axx), s[1] += total64(axy), s[2] += total64(ayy), s[3] += total32(ax), s[4] += total32(ay);
  return k;
}

// s[0..3) += sum d, d gx, d gy with d = T - W, the same way. Both forced inline: on aarch64 GCC
// kept them out of line, 0.01 M instructions per frame more than the code they replaced.
template <class L>
__attribute__((always_inline)) inline int add_error_lanes(const Px* t, const Px* w, const Px* gx, const Px* gy,
                                                           int nn, int k, std::int64_t* s) {
  typename L::Acc64 adx = L::zero64(), ady = adx;
  typename L::Acc32 ad = L::zero32();
  for (; k + L::kN <= nn; k += L::kN) {
    const auto d = L::sub(L::load(t + k), L::load(w + k));
    ad = add_values(ad, d);
    adx = add_products(adx, d, L::load(gx + k));
    ady = add_products(ady, d, L::load(gy + k));
  }
  s[0] += total32(ad), s[1] += total64(adx), s[2] += total64(ady);
  return k;
}
#endif

// Structure tensor of the template gradients and their plain sums, in (128 x grey/px)^2 and
// 128 x grey/px (the arrays hold twice the gradients).
struct GradientSums {
  float gxx = 0.0f, gxy = 0.0f, gyy = 0.0f, gx = 0.0f, gy = 0.0f;
};

GradientSums gradient_sums(const Px* gx, const Px* gy, int nn) {
  std::int64_t v[5] = {0, 0, 0, 0, 0};
  int k = 0;
#if defined(__AVX2__)
  if (nn >= kPxLanes16) k = add_gradient_lanes<PxLanes16>(gx, gy, nn, k, v);
#endif
#if defined(__ARM_NEON) || defined(__SSE2__)
  k = add_gradient_lanes<PxLanes>(gx, gy, nn, k, v);
#endif
  std::int64_t sxx = v[0], sxy = v[1], syy = v[2], sx = v[3], sy = v[4];
  for (; k < nn; ++k) {
    const std::int64_t a = gx[k], b = gy[k];
    sxx += a * a, sxy += a * b, syy += b * b, sx += a, sy += b;
  }
  return {static_cast<float>(0.25 * static_cast<double>(sxx)), static_cast<float>(0.25 * static_cast<double>(sxy)),
          static_cast<float>(0.25 * static_cast<double>(syy)), static_cast<float>(0.5 * static_cast<double>(sx)),
          static_cast<float>(0.5 * static_cast<double>(sy))};
}

// sum d, sum d gx, sum d gy with d = T - W (|d| <= 32640) and g the gradient (half the arrays').
struct ErrorSums {
  float d = 0.0f, dgx = 0.0f, dgy = 0.0f;
};

ErrorSums error_sums_from(std::int64_t sd, std::int64_t sdx, std::int64_t sdy) {
  return {static_cast<float>(sd), static_cast<float>(0.5 * static_cast<double>(sdx)),
          static_cast<float>(0.5 * static_cast<double>(sdy))};
}

ErrorSums error_sums(const Px* t, const Px* w, const Px* gx, const Px* gy, int nn) {
  std::int64_t v[3] = {0, 0, 0};
  int k = 0;
#if defined(__AVX2__)
  if (nn >= kPxLanes16) k = add_error_lanes<PxLanes16>(t, w, gx, gy, nn, k, v);
#endif
#if defined(__ARM_NEON) || defined(__SSE2__)
  k = add_error_lanes<PxLanes>(t, w, gx, gy, nn, k, v);
#endif
  std::int64_t sd = v[0], sdx = v[1], sdy = v[2];
  for (; k < nn; ++k) {
    const std::int64_t d = t[k] - w[k];
    sd += d, sdx += d * gx[k], sdy += d * gy[k];
  }
  return error_sums_from(sd, sdx, sdy);
}

#if defined(__ARM_NEON) || defined(__SSE2__)
// error_sums' three sums, vector by vector: d = T - W and the template gradients, 8 each.
struct ErrorLanes {
#if defined(__ARM_NEON)
  int32x4_t d = vdupq_n_s32(0);
  int64x2_t dx = vdupq_n_s64(0), dy = vdupq_n_s64(0);
  static int16x8_t difference(const Px* t, uint16x8_t w) { return vsubq_s16(load_px(t), vreinterpretq_s16_u16(w)); }
  // The lanes below `count` of v, the others 0.
  static int16x8_t first_lanes(int16x8_t v, int count) {
    const int16x8_t index = {0, 1, 2, 3, 4, 5, 6, 7};
    return vandq_s16(v, vreinterpretq_s16_u16(vcltq_s16(index, vdupq_n_s16(static_cast<std::int16_t>(count)))));
  }
#else
  __m128i d = _mm_setzero_si128(), dx = _mm_setzero_si128(), dy = _mm_setzero_si128();
  static __m128i difference(const Px* t, __m128i w) { return _mm_sub_epi16(load_px(t), w); }
  static __m128i first_lanes(__m128i v, int count) {
    const __m128i index = _mm_setr_epi16(0, 1, 2, 3, 4, 5, 6, 7);
    return _mm_and_si128(v, _mm_cmplt_epi16(index, _mm_set1_epi16(static_cast<short>(count))));
  }
#endif
  template <class V>
  void add(V diff, const Px* gx, const Px* gy) {
    d = add_values(d, diff);
    dx = add_products(dx, diff, load_px(gx));
    dy = add_products(dy, diff, load_px(gy));
  }
  ErrorSums sums() const { return error_sums_from(total32(d), total64(dx), total64(dy)); }
};
#endif

// T - W at 8 elements as two float lanes (exact: |T - W| <= 32640).
inline void difference_lanes(const Px* t, const Px* w, FloatLanes* lo, FloatLanes* hi) {
#if defined(__ARM_NEON)
  const int16x8_t d = vsubq_s16(load_px(t), load_px(w));
  *lo = vcvtq_f32_s32(vmovl_s16(vget_low_s16(d)));
  *hi = vcvtq_f32_s32(vmovl_s16(vget_high_s16(d)));
#elif defined(__SSE2__)
  const __m128i d = _mm_sub_epi16(load_px(t), load_px(w));
  *lo = _mm_cvtepi32_ps(_mm_srai_epi32(_mm_unpacklo_epi16(d, d), 16));
  *hi = _mm_cvtepi32_ps(_mm_srai_epi32(_mm_unpackhi_epi16(d, d), 16));
#else
  for (int i = 0; i < 4; ++i) {
    (*lo)[i] = static_cast<float>(t[i] - w[i]);
    (*hi)[i] = static_cast<float>(t[i + 4] - w[i + 4]);
  }
#endif
}

// Mean |T - W - offset| with the offset the mean of T - W: the sum of T - W exact, the absolute
// deviations in 4 float lanes with a fixed order (the elements of whole groups of 8 in lane k % 4,
// the lanes added 0..3, then the last nn % 8 one by one).
float mean_abs_error(const Px* t, const Px* w, int nn) {
  std::int64_t sum_d = 0;
  int j = 0;
#if defined(__ARM_NEON)
  int32x4_t ad = vdupq_n_s32(0);
  for (; j + kPxLanes <= nn; j += kPxLanes) ad = add_values(ad, vsubq_s16(load_px(t + j), load_px(w + j)));
  sum_d = total32(ad);
#elif defined(__SSE2__)
  __m128i ad = _mm_setzero_si128();
  for (; j + kPxLanes <= nn; j += kPxLanes) ad = add_values(ad, _mm_sub_epi16(load_px(t + j), load_px(w + j)));
  sum_d = total32(ad);
#endif
  for (; j < nn; ++j) sum_d += t[j] - w[j];
  const float inv_area = 1.0f / static_cast<float>(nn);
  const float mean_d = static_cast<float>(sum_d) * inv_area;
  const FloatLanes mean{mean_d, mean_d, mean_d, mean_d};
  FloatLanes sa{};
  int k = 0;
  for (; k + kPxLanes <= nn; k += kPxLanes) {
    FloatLanes lo, hi;
    difference_lanes(t + k, w + k, &lo, &hi);
    lo -= mean;
    hi -= mean;
    sa += lo < 0.0f ? -lo : lo;
    sa += hi < 0.0f ? -hi : hi;
  }
  float sum_abs = 0.0f;
  for (int i = 0; i < kFloatLanes; ++i) sum_abs += sa[i];
  for (; k < nn; ++k) sum_abs += std::fabs(static_cast<float>(t[k] - w[k]) - mean_d);
  return sum_abs * inv_area;
}

// Bilinear sampling in fixed point, as OpenCV's pyramidal LK (there with 14-bit weights): the
// four weights are integers summing to 128, so a sample is an integer sum of pixel x weight
// products (at most 255 x 128, 16 bits) and the float out is that sum / 128, exact. The
// arithmetic is integer throughout: every machine gives the same floats, with 8 samples per
// vector instruction (NEON's u8 x u8 multiply-accumulate; SSE2 on 16-bit lanes). The position
// is quantized in steps of 1/128 px (within 1/256 px), below the 0.01 px at which the tracker stops.
constexpr int kWeightBits = 7;
constexpr int kWeightOne = 1 << kWeightBits;
constexpr int kChunk = 8;  // samples per vector step

struct Weights {
  int w00, w01, w10, w11;
};

// From the fractions (ax, ay) in [0, 1): X = round(128 ax), Y = round(128 ay); w11 = round(X Y /
// 128) and the others by difference, so that none is negative and they sum to 128.
Weights quantized_weights(float ax, float ay) {
  const int X = static_cast<int>(ax * static_cast<float>(kWeightOne) + 0.5f);
  const int Y = static_cast<int>(ay * static_cast<float>(kWeightOne) + 0.5f);
  const int w11 = (X * Y + kWeightOne / 2) >> kWeightBits;
  return {kWeightOne - X - Y + w11, X - w11, Y - w11, w11};
}

// A patch whose top-left sample sits at (x, y): the integer pixel under it and the weights of
// its fractions, the same for every sampler (the direct sparse template must equal sample_fixed).
struct PatchOrigin {
  int x0 = 0, y0 = 0;
  Weights w{};
};

PatchOrigin patch_origin(float x, float y) {
  const float fx0 = std::floor(x), fy0 = std::floor(y);
  return {static_cast<int>(fx0), static_cast<int>(fy0), quantized_weights(x - fx0, y - fy0)};
}

// 8 integer sums of pixel x weight (below 2^15) out: as float grey levels, or the sums (Px).
#if defined(__ARM_NEON)
inline void store_sums(uint16x8_t s, Px* out) { vst1q_s16(out, vreinterpretq_s16_u16(s)); }
inline void store_sums(uint16x8_t s, float* out) {
  float32x4_t lo = vcvtq_f32_u32(vmovl_u16(vget_low_u16(s))), hi = vcvtq_f32_u32(vmovl_u16(vget_high_u16(s)));
  lo = vmulq_n_f32(lo, 1.0f / static_cast<float>(kWeightOne));
  hi = vmulq_n_f32(hi, 1.0f / static_cast<float>(kWeightOne));
  vst1q_f32(out, lo);
  vst1q_f32(out + 4, hi);
}
#elif defined(__SSE2__)
inline void store_sums(__m128i s, Px* out) { _mm_storeu_si128(reinterpret_cast<__m128i*>(out), s); }
inline void store_sums(__m128i s, float* out) {
  const __m128i zero = _mm_setzero_si128();
  __m128 lo = _mm_cvtepi32_ps(_mm_unpacklo_epi16(s, zero)), hi = _mm_cvtepi32_ps(_mm_unpackhi_epi16(s, zero));
  lo = _mm_mul_ps(lo, _mm_set1_ps(1.0f / static_cast<float>(kWeightOne)));
  hi = _mm_mul_ps(hi, _mm_set1_ps(1.0f / static_cast<float>(kWeightOne)));
  _mm_storeu_ps(out, lo);
  _mm_storeu_ps(out + 4, hi);
}
#endif

// A sample's integer sum v out: float grey levels, or v itself (Px).
template <class Out>
inline Out sample_value(int v) {
  if constexpr (std::is_same_v<Out, float>) {
    return static_cast<float>(v) * (1.0f / static_cast<float>(kWeightOne));
  } else {
    return static_cast<Out>(v);
  }
}

#if defined(__ARM_NEON)
using SumVec = uint16x8_t;  // 8 samples' integer sums
#elif defined(__SSE2__)
using SumVec = __m128i;
#endif

#if defined(__ARM_NEON) || defined(__SSE2__)
// The integer sums of 8 samples from two source rows (each read at i .. i + 8, 9 pixels).
inline SumVec chunk_sums(const std::uint8_t* r0, const std::uint8_t* r1, const Weights& w) {
#if defined(__ARM_NEON)
  uint16x8_t s = vmull_u8(vld1_u8(r0), vdup_n_u8(static_cast<std::uint8_t>(w.w00)));
  s = vmlal_u8(s, vld1_u8(r0 + 1), vdup_n_u8(static_cast<std::uint8_t>(w.w01)));
  s = vmlal_u8(s, vld1_u8(r1), vdup_n_u8(static_cast<std::uint8_t>(w.w10)));
  return vmlal_u8(s, vld1_u8(r1 + 1), vdup_n_u8(static_cast<std::uint8_t>(w.w11)));
#else
  const __m128i zero = _mm_setzero_si128();
  auto px = [zero](const std::uint8_t* p) {
    return _mm_unpacklo_epi8(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)), zero);
  };
  // Products and sums below 2^15: 16-bit lanes hold them exactly.
  __m128i s = _mm_mullo_epi16(px(r0), _mm_set1_epi16(static_cast<short>(w.w00)));
  s = _mm_add_epi16(s, _mm_mullo_epi16(px(r0 + 1), _mm_set1_epi16(static_cast<short>(w.w01))));
  s = _mm_add_epi16(s, _mm_mullo_epi16(px(r1), _mm_set1_epi16(static_cast<short>(w.w10))));
  return _mm_add_epi16(s, _mm_mullo_epi16(px(r1 + 1), _mm_set1_epi16(static_cast<short>(w.w11))));
#endif
}

// The sums of 16 samples (each source row read at i .. i + 16, 17 pixels): two chunks, on aarch64
// and AVX2 in one step of 16-byte loads (the same integer sums; SSE2 gained nothing from it).
inline void chunk16_sums(const std::uint8_t* r0, const std::uint8_t* r1, const Weights& w, SumVec* lo, SumVec* hi) {
#if defined(__ARM_NEON) && defined(__aarch64__)
  const uint8x16_t w00 = vdupq_n_u8(static_cast<std::uint8_t>(w.w00)), w01 = vdupq_n_u8(static_cast<std::uint8_t>(w.w01));
  const uint8x16_t w10 = vdupq_n_u8(static_cast<std::uint8_t>(w.w10)), w11 = vdupq_n_u8(static_cast<std::uint8_t>(w.w11));
  const uint8x16_t a0 = vld1q_u8(r0), a1 = vld1q_u8(r0 + 1), b0 = vld1q_u8(r1), b1 = vld1q_u8(r1 + 1);
  uint16x8_t l = vmull_u8(vget_low_u8(a0), vget_low_u8(w00));
  uint16x8_t h = vmull_high_u8(a0, w00);
  l = vmlal_u8(l, vget_low_u8(a1), vget_low_u8(w01));
  h = vmlal_high_u8(h, a1, w01);
  l = vmlal_u8(l, vget_low_u8(b0), vget_low_u8(w10));
  h = vmlal_high_u8(h, b0, w10);
  *lo = vmlal_u8(l, vget_low_u8(b1), vget_low_u8(w11));
  *hi = vmlal_high_u8(h, b1, w11);
#elif defined(__AVX2__)
  auto px16 = [](const std::uint8_t* p) {
    return _mm256_cvtepu8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
  };
  __m256i s = _mm256_mullo_epi16(px16(r0), _mm256_set1_epi16(static_cast<short>(w.w00)));
  s = _mm256_add_epi16(s, _mm256_mullo_epi16(px16(r0 + 1), _mm256_set1_epi16(static_cast<short>(w.w01))));
  s = _mm256_add_epi16(s, _mm256_mullo_epi16(px16(r1), _mm256_set1_epi16(static_cast<short>(w.w10))));
  s = _mm256_add_epi16(s, _mm256_mullo_epi16(px16(r1 + 1), _mm256_set1_epi16(static_cast<short>(w.w11))));
  *lo = _mm256_castsi256_si128(s);
  *hi = _mm256_extracti128_si256(s, 1);
#else
  *lo = chunk_sums(r0, r1, w);
  *hi = chunk_sums(r0 + kChunk, r1 + kChunk, w);
#endif
}

// The sums of 8 samples two pixels apart, each from pixels 2i and 2i + 1 of the two source rows
// (16 bytes read from each): chunk_sums' formula on the even and odd pixels.
inline SumVec chunk_step2_sums(const std::uint8_t* r0, const std::uint8_t* r1, const Weights& w) {
#if defined(__ARM_NEON)
  const uint8x8x2_t a = vld2_u8(r0), b = vld2_u8(r1);  // val[0]: pixels 2i, val[1]: 2i + 1
  uint16x8_t s = vmull_u8(a.val[0], vdup_n_u8(static_cast<std::uint8_t>(w.w00)));
  s = vmlal_u8(s, a.val[1], vdup_n_u8(static_cast<std::uint8_t>(w.w01)));
  s = vmlal_u8(s, b.val[0], vdup_n_u8(static_cast<std::uint8_t>(w.w10)));
  return vmlal_u8(s, b.val[1], vdup_n_u8(static_cast<std::uint8_t>(w.w11)));
#else
  const __m128i low_bytes = _mm_set1_epi16(0x00FF);
  const __m128i a = _mm_loadu_si128(reinterpret_cast<const __m128i*>(r0));
  const __m128i b = _mm_loadu_si128(reinterpret_cast<const __m128i*>(r1));
  // 16-bit lanes: the low byte is pixel 2i, the high byte pixel 2i + 1.
  __m128i s = _mm_mullo_epi16(_mm_and_si128(a, low_bytes), _mm_set1_epi16(static_cast<short>(w.w00)));
  s = _mm_add_epi16(s, _mm_mullo_epi16(_mm_srli_epi16(a, 8), _mm_set1_epi16(static_cast<short>(w.w01))));
  s = _mm_add_epi16(s, _mm_mullo_epi16(_mm_and_si128(b, low_bytes), _mm_set1_epi16(static_cast<short>(w.w10))));
  return _mm_add_epi16(s, _mm_mullo_epi16(_mm_srli_epi16(b, 8), _mm_set1_epi16(static_cast<short>(w.w11))));
#endif
}
#endif

// 8 samples from two source rows (each read at i .. i + 8, 9 pixels): float grey levels, or (Px)
// 128 times them, the integer sums themselves. The tracker works on the latter: its thresholds
// are scaled to match.
template <class Out>
inline void sample_chunk(const std::uint8_t* r0, const std::uint8_t* r1, const Weights& w, Out* out) {
#if defined(__ARM_NEON) || defined(__SSE2__)
  store_sums(chunk_sums(r0, r1, w), out);
#else
  for (int i = 0; i < kChunk; ++i) {
    out[i] = sample_value<Out>(w.w00 * r0[i] + w.w01 * r0[i + 1] + w.w10 * r1[i] + w.w11 * r1[i + 1]);
  }
#endif
}

// 16 samples from two source rows (each read at i .. i + 16, 17 pixels).
template <class Out>
inline void sample_chunk16(const std::uint8_t* r0, const std::uint8_t* r1, const Weights& w, Out* out) {
#if defined(__ARM_NEON) || defined(__SSE2__)
  SumVec lo, hi;
  chunk16_sums(r0, r1, w, &lo, &hi);
  store_sums(lo, out);
  store_sums(hi, out + kChunk);
#else
  sample_chunk<Out>(r0, r1, w, out);
  sample_chunk<Out>(r0 + kChunk, r1 + kChunk, w, out + kChunk);
#endif
}

// One patch row of `cols` samples (whole chunks) from source rows r0, r1 into out: 16 at a time,
// then 8.
template <class Out>
inline void sample_row(const std::uint8_t* r0, const std::uint8_t* r1, const Weights& w, int cols, Out* out) {
  int i = 0;
  for (; i + 2 * kChunk <= cols; i += 2 * kChunk) sample_chunk16<Out>(r0 + i, r1 + i, w, out + i);
  if (i < cols) sample_chunk<Out>(r0 + i, r1 + i, w, out + i);
}

// The same row's first n samples exactly (n >= kChunk), for a row whose whole chunks would run
// past the patch: whole chunks, then the chunk ending at sample n (its first samples again, the
// same values).
template <class Out>
inline void sample_row_exact(const std::uint8_t* r0, const std::uint8_t* r1, const Weights& w, int n, Out* out) {
  int i = 0;
  for (; i + kChunk <= n; i += kChunk) sample_chunk<Out>(r0 + i, r1 + i, w, out + i);
  if (i < n) sample_chunk<Out>(r0 + n - kChunk, r1 + n - kChunk, w, out + n - kChunk);
}

// The widest source row: the largest patch (window + 2) in whole chunks, plus the right neighbour.
constexpr int kMaxSrcRow = (KltOptions::kMaxWindowPx + 2 + kChunk - 1) / kChunk * kChunk + 1;
constexpr int kMaxSrcRows = KltOptions::kMaxWindowPx + 3;
// The sparse window: every other pixel of the window, window_px / 2 + 1 samples a side.
constexpr int kMaxSparseSide = KltOptions::kMaxWindowPx / 2 + 1;
constexpr int kMaxSparseCols = (kMaxSparseSide + kChunk - 1) / kChunk * kChunk;  // samples, whole chunks
constexpr int kMaxSparseSrcRow = 2 * kMaxSparseCols;                                 // bytes a row reads
static_assert(2 * kMaxSparseSide <= kMaxSrcRows, "the sparse sampler reads two source rows per sample row");

// Columns x0 .. x0 + cols - 1 of image can be read in place: inside it or its margin (a pyramid
// level's repeated edge pixels, ImageView::margin), where a pixel is what clamping would read.
inline bool columns_readable(const ImageView& image, int x0, int cols) {
  return x0 >= -image.margin && x0 + cols <= image.width + image.margin;
}
inline bool rows_readable(const ImageView& image, int y0, int rows) {
  return y0 >= -image.margin && y0 + rows <= image.height + image.margin;
}

// Source pixels x0 .. x0 + src - 1 of row r (width w), the ones outside the row repeating its
// end pixels.
void clamped_row(const std::uint8_t* r, int w, int x0, int src, std::uint8_t* out) {
  const int lo = std::clamp(-x0, 0, src);       // first i inside the row
  const int hi = std::clamp(w - x0, lo, src);   // one past the last i inside
  std::memset(out, r[0], static_cast<std::size_t>(lo));
  if (hi > lo) std::memcpy(out + lo, r + x0 + lo, static_cast<std::size_t>(hi - lo));
  std::memset(out + hi, r[w - 1], static_cast<std::size_t>(src - hi));
}

// sample_patch_bilinear's contract (n checked by the caller; Px: 128 times the grey levels). The
// pixels are read in place when the columns under the patch (whole chunks + 1) lie inside the
// image or its margin; a block that crosses them is copied with the border pixels repeated.
template <class Out>
void sample_fixed(const ImageView& image, float x, float y, int n, Out* out) {
  const PatchOrigin origin = patch_origin(x, y);
  const int x0 = origin.x0, y0 = origin.y0;
  const Weights& w = origin.w;
  const int cols = (n + kChunk - 1) / kChunk * kChunk;
  const int src = cols + 1;
  alignas(16) Out scratch[kMaxSrcRow];
  const bool inside = columns_readable(image, x0, src);
  if (inside && rows_readable(image, y0, n + 1)) {
    // The common case, away from every edge: the source rows in place, walked by stride. Rows
    // in whole chunks as below; only the last rows, whose chunks would run past the patch, take
    // their n samples exactly (or, below a chunk, go through the scratch row).
    const long stride = image.stride;
    const std::uint8_t* r = image.row(y0) + x0;
    const int direct = std::min(n, n * n >= cols ? (n * n - cols) / n + 1 : 0);
    int j = 0;
    for (; j < direct; ++j, r += stride) sample_row<Out>(r, r + stride, w, cols, out + j * n);
    for (; j < n; ++j, r += stride) {
      if (n >= kChunk) {
        sample_row_exact<Out>(r, r + stride, w, n, out + j * n);
        continue;
      }
      sample_row<Out>(r, r + stride, w, cols, scratch);
      std::memcpy(out + j * n, scratch, sizeof(Out) * static_cast<std::size_t>(n));
    }
    return;
  }
  const std::uint8_t* rows[kMaxSrcRows];
  std::uint8_t copy[kMaxSrcRows][kMaxSrcRow];
  const int ymax = image.height - 1;
  if (inside) {
    // Rows above or below the image repeat the edge row: pointing at it is the copy.
    for (int j = 0; j <= n; ++j) rows[j] = image.row(std::clamp(y0 + j, 0, ymax)) + x0;
  } else {
    for (int j = 0; j <= n; ++j) {
      clamped_row(image.row(std::clamp(y0 + j, 0, ymax)), image.width, x0, src, copy[j]);
      rows[j] = copy[j];
    }
  }
  // Each row in whole chunks as above: the samples past n land on the next row's start, which
  // that row overwrites; a row whose chunks would run past the patch takes its n samples exactly
  // (below a chunk, through the scratch row).
  for (int j = 0; j < n; ++j) {
    if (j * n + cols <= n * n) {
      sample_row<Out>(rows[j], rows[j + 1], w, cols, out + j * n);
    } else if (n >= kChunk) {
      sample_row_exact<Out>(rows[j], rows[j + 1], w, n, out + j * n);
    } else {
      sample_row<Out>(rows[j], rows[j + 1], w, cols, scratch);
      std::memcpy(out + j * n, scratch, sizeof(Out) * static_cast<std::size_t>(n));
    }
  }
}

// 8 samples two pixels apart, each from pixels 2i and 2i + 1 of the two source rows (16 bytes
// read from each): the same integer formula as sample_chunk, on the even and odd pixels.
template <class Out>
inline void sample_chunk_step2(const std::uint8_t* r0, const std::uint8_t* r1, const Weights& w, Out* out) {
#if defined(__ARM_NEON) || defined(__SSE2__)
  store_sums(chunk_step2_sums(r0, r1, w), out);
#else
  for (int i = 0; i < kChunk; ++i) {
    out[i] = sample_value<Out>(w.w00 * r0[2 * i] + w.w01 * r0[2 * i + 1] + w.w10 * r1[2 * i] + w.w11 * r1[2 * i + 1]);
  }
#endif
}

// sample_sparse_bilinear's contract (Px: 128 times the grey levels): the samples of
// sample_fixed's (2n - 1)-wide patch at (x, y) on its even rows and columns (the same weights). In
// place when the source block (whole chunks of 16 pixels) lies inside the image or its margin, else from copied
// rows with the border pixels repeated.
template <class Out>
void sample_fixed_step2(const ImageView& image, float x, float y, int n, Out* out) {
  const PatchOrigin origin = patch_origin(x, y);
  const int x0 = origin.x0, y0 = origin.y0;
  const Weights& w = origin.w;
  const int cols = (n + kChunk - 1) / kChunk * kChunk;
  const int src = 2 * cols;
  const std::uint8_t* rows[kMaxSrcRows];
  std::uint8_t copy[kMaxSrcRows][kMaxSparseSrcRow];
  const int ymax = image.height - 1;
  const bool inside = columns_readable(image, x0, src);
  if (inside && rows_readable(image, y0, 2 * n) && n % kChunk == 0) {
    // The common case (window_px 15: one chunk per row), inside the image or its margin: the
    // source rows in place, walked by stride.
    const long stride = image.stride;
    const std::uint8_t* r = image.row(y0) + x0;
    // Row j's source rows from its index (a pointer stepped past the last row could leave the
    // image's storage: its rows end at y0 + 2n <= height).
    if (n == kChunk) {  // one step a row
      for (int j = 0; j < n; ++j) sample_chunk_step2<Out>(r + 2 * j * stride, r + (2 * j + 1) * stride, w, out + j * n);
      return;
    }
    for (int j = 0; j < n; ++j) {
      const std::uint8_t* rj = r + 2 * j * stride;
      for (int i = 0; i < n; i += kChunk) sample_chunk_step2<Out>(rj + 2 * i, rj + stride + 2 * i, w, out + j * n + i);
    }
    return;
  }
  // Sample row j reads source rows y0 + 2j and y0 + 2j + 1.
  for (int j = 0; j < n; ++j) {
    for (int k = 0; k < 2; ++k) {
      const std::uint8_t* r = image.row(std::clamp(y0 + 2 * j + k, 0, ymax));
      if (inside) {
        rows[2 * j + k] = r + x0;
      } else {
        clamped_row(r, image.width, x0, src, copy[2 * j + k]);
        rows[2 * j + k] = copy[2 * j + k];
      }
    }
  }
  alignas(16) Out scratch[kMaxSparseCols];
  for (int j = 0; j < n; ++j) {
    Out* o = j * n + cols <= n * n ? out + j * n : scratch;
    for (int i = 0; i < cols; i += kChunk)
      sample_chunk_step2<Out>(rows[2 * j] + 2 * i, rows[2 * j + 1] + 2 * i, w, o + i);
    if (o == scratch) std::memcpy(out + j * n, scratch, sizeof(Out) * static_cast<std::size_t>(n));
  }
}

void check_patch_size(int n) {
  if (n < 1 || n > KltOptions::kMaxWindowPx + 2) {
    throw std::invalid_argument("sample_patch_bilinear: n must be in 1.." + std::to_string(KltOptions::kMaxWindowPx + 2) +
                                ", got " + std::to_string(n));
  }
}

// The n x n template (the centre of the (n + 2)^2 patch ext) and its central differences (twice
// the gradients), row by row in whole 8-lane vectors: the lanes past n land on the next row's
// start, which that row overwrites, and past the last row in the arrays' kPxLanes of padding
// (ext, too, is read up to kPxLanes past its end). Integers: the same values in any lane split.
void template_and_gradients(const Px* ext, int n, Px* tmpl, Px* gx, Px* gy) {
  typedef short PxVec __attribute__((vector_size(16)));
  auto load = [](const Px* p) {
    PxVec v;
    std::memcpy(&v, p, sizeof v);
    return v;
  };
  auto store = [](Px* p, PxVec v) { std::memcpy(p, &v, sizeof v); };
  const int ne = n + 2;
  const int cols = (n + kPxLanes - 1) / kPxLanes * kPxLanes;
  for (int j = 0; j < n; ++j) {
    const Px* c = ext + (j + 1) * ne + 1;
    const int k0 = j * n;
    for (int i = 0; i < cols; i += kPxLanes) {
      store(tmpl + k0 + i, load(c + i));
      store(gx + k0 + i, load(c + i + 1) - load(c + i - 1));
      store(gy + k0 + i, load(c + i + ne) - load(c + i - ne));
    }
  }
}

}  // namespace

void KltOptions::validate() const {
  if (window_px < 5 || window_px > kMaxWindowPx || window_px % 2 == 0) {
    throw std::invalid_argument("KltOptions.window_px must be odd in 5.." + std::to_string(kMaxWindowPx) +
                                ", got " + std::to_string(window_px));
  }
  if (max_iterations < 1) throw std::invalid_argument("KltOptions.max_iterations must be >= 1, got " + std::to_string(max_iterations));
  if (!(epsilon_px > 0.0f)) throw std::invalid_argument("KltOptions.epsilon_px must be > 0, got " + std::to_string(epsilon_px));
  if (!(coarse_epsilon_px > 0.0f)) {
    throw std::invalid_argument("KltOptions.coarse_epsilon_px must be > 0, got " + std::to_string(coarse_epsilon_px));
  }
  if (!(min_eigen >= 0.0f)) throw std::invalid_argument("KltOptions.min_eigen must be >= 0, got " + std::to_string(min_eigen));
  if (sparse_from_level < 0 || sparse_from_level > capacity::kMaxPyramidLevels) {
    throw std::invalid_argument("KltOptions.sparse_from_level must be in 0.." + std::to_string(capacity::kMaxPyramidLevels) +
                                ", got " + std::to_string(sparse_from_level));
  }
  if (!(max_mean_abs_error > 0.0f)) {
    throw std::invalid_argument("KltOptions.max_mean_abs_error must be > 0, got " + std::to_string(max_mean_abs_error));
  }
}

void sample_patch_bilinear(const ImageView& image, float x, float y, int n, float* out) {
  check_patch_size(n);
  sample_fixed<float>(image, x, y, n, out);
}

void sample_sparse_bilinear(const ImageView& image, float x, float y, int n, float* out) {
  if (n < 1 || n > kMaxSparseSide) {
    throw std::invalid_argument("sample_sparse_bilinear: n must be in 1.." + std::to_string(kMaxSparseSide) + ", got " +
                                std::to_string(n));
  }
  sample_fixed_step2<float>(image, x, y, n, out);
}

namespace {

// One klt_track call's buffers: the patch a template is cut from, a template with its gradients
// when no cache keeps it, and the warped window (stack, no allocation).
struct KltWorkspace {
  static constexpr int kMaxN = KltOptions::kMaxWindowPx;
  static constexpr int kMaxT = kMaxN + 2;
  // + kPxLanes: template_and_gradients reads and writes whole vectors past the last row's end.
  alignas(16) Px tmpl_ext[kMaxT * kMaxT + kPxLanes];
  alignas(16) Px tmpl[kMaxN * kMaxN + kPxLanes];
  alignas(16) Px gx[kMaxN * kMaxN + kPxLanes];
  alignas(16) Px gy[kMaxN * kMaxN + kPxLanes];
  alignas(16) Px warped[kMaxN * kMaxN + kPxLanes];
  // A sparse level's template: every other sample of the (dense) template, and its gradients.
  alignas(16) Px sparse_tmpl[kMaxSparseSide * kMaxSparseSide + kPxLanes];
  alignas(16) Px sparse_gx[kMaxSparseSide * kMaxSparseSide + kPxLanes];
  alignas(16) Px sparse_gy[kMaxSparseSide * kMaxSparseSide + kPxLanes];
};

// A level's template, in the workspace or in a cache block.
struct TemplateRef {
  Px* tmpl = nullptr;
  Px* gx = nullptr;
  Px* gy = nullptr;
  GradientSums gs;
};

// Units of each array in a cache block, whole vectors with kPxLanes to spare (as the workspace).
constexpr int template_stride(int n) { return (n * n + 2 * kPxLanes - 1) / kPxLanes * kPxLanes; }

// even_samples' last read of a template (last sparse row, last group of 8) lies inside the
// template_stride(n) units of a cache block and the workspace's arrays, for every odd window.
constexpr bool sparse_reads_fit() {
  for (int n = 1; n <= KltOptions::kMaxWindowPx; n += 2) {
    const int side = n / 2 + 1, groups = (side + kPxLanes - 1) / kPxLanes * kPxLanes;
    const int last = 2 * (side - 1) * n + 2 * groups - 1;
    if (last >= template_stride(n) || last >= KltOptions::kMaxWindowPx * KltOptions::kMaxWindowPx + kPxLanes) return false;
  }
  return true;
}
static_assert(sparse_reads_fit(), "even_samples reads past a template's storage");

// sample_error_sums' dense rows (9 .. 16 samples, one vector step each) read a template's arrays
// and write the window buffer up to 16 - n samples past the window: inside template_stride(n)
// and the workspace's arrays, for every odd window it serves.
constexpr bool fused_reads_fit() {
  for (int n = 9; n <= 2 * kPxLanes; n += 2) {
    const int end = (n - 1) * n + 2 * kPxLanes;  // one past the last unit touched
    if (end > template_stride(n) || end > KltOptions::kMaxWindowPx * KltOptions::kMaxWindowPx + kPxLanes) return false;
  }
  return true;
}
static_assert(fused_reads_fit(), "sample_error_sums reads past a template's storage");

// A cache block: template, gradients, then the sums and the usable flag (floats, copied in and
// out: kSumFloats of them in 2 * kSumFloats units).
constexpr int kSumFloats = 8;
constexpr int kSumUnits = 2 * kSumFloats;

// The smallest eigenvalue of the mean structure tensor is at least min_eigen (the samples are
// 128 x grey levels, sample_chunk: the tensor is 128^2 x (grey/px)^2).
bool textured(const GradientSums& gs, int samples, const KltOptions& options) {
  const float inv_area = 1.0f / static_cast<float>(samples);
  const float a = gs.gxx * inv_area, b = gs.gxy * inv_area, c2 = gs.gyy * inv_area;
  const float min_eig = 0.5f * ((a + c2) - std::sqrt((a - c2) * (a - c2) + 4.0f * b * b));
  constexpr float kScale2 = static_cast<float>(kWeightOne * kWeightOne);
  return min_eig >= options.min_eigen * kScale2 && min_eig > 0.0f;
}

// Samples the template around p in I and its gradients into t (arrays of n * n + kPxLanes units).
// False when the window is untextured: the smallest eigenvalue of the mean structure tensor is
// below min_eigen.
bool prepare_template(const ImageView& I, const Eigen::Vector2f& p, const KltOptions& options, Px* tmpl_ext,
                      TemplateRef* t) {
  const int n = options.window_px, half = n / 2, ne = n + 2, nn = n * n;
  sample_fixed<Px>(I, p.x() - static_cast<float>(half + 1), p.y() - static_cast<float>(half + 1), ne, tmpl_ext);
  std::fill(tmpl_ext + ne * ne, tmpl_ext + ne * ne + kPxLanes, Px{0});  // read by the last row's spare lanes
  template_and_gradients(tmpl_ext, n, t->tmpl, t->gx, t->gy);
  t->gs = gradient_sums(t->gx, t->gy, nn);
  return textured(t->gs, nn, options);
}

// The samples a level's iterations use: the whole window (step 1, side window_px) or every other
// pixel in both directions (step 2, side window_px / 2 + 1), both from the window's top-left.
struct WindowGrid {
  int side = 0;
  int step = 1;
  int samples() const { return side * side; }
};

// dst[i] = src[2 i] for i < count, 8 at a time: reads src up to src[2 c - 1] and writes dst up
// to dst[c - 1], c = count rounded up to 8. A template's last sparse row then reads past the
// template (sparse_reads_fit above checks every window), into lanes that are dropped, and writes
// into the next sparse row, which comes after it, or the sparse arrays' spare lanes.
inline void even_samples(const Px* src, Px* dst, int count) {
  for (int i = 0; i < count; i += kPxLanes, src += 2 * kPxLanes, dst += kPxLanes) {
#if defined(__ARM_NEON)
    vst1q_s16(dst, vld2q_s16(src).val[0]);
#elif defined(__SSE2__)
    // The even elements are the low halves of the 32-bit lanes: sign-extended in place, then packed.
    const __m128i a = _mm_srai_epi32(_mm_slli_epi32(load_px(src), 16), 16);
    const __m128i b = _mm_srai_epi32(_mm_slli_epi32(load_px(src + kPxLanes), 16), 16);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(dst), _mm_packs_epi32(a, b));
#else
    for (int k = 0; k < kPxLanes; ++k) dst[k] = src[2 * k];
#endif
  }
}

// The sparse grid's template from the dense one t (window n): its samples and gradients at the
// even rows and columns, and their sums. False when that sparse template is untextured (the
// level then iterates on the dense one).
bool sparse_template(const TemplateRef& t, int n, const KltOptions& options, KltWorkspace* ws, TemplateRef* s) {
  const int side = n / 2 + 1;
  for (int j = 0; j < side; ++j) {
    const int d = 2 * j * n, k = j * side;
    even_samples(t.tmpl + d, ws->sparse_tmpl + k, side);
    even_samples(t.gx + d, ws->sparse_gx + k, side);
    even_samples(t.gy + d, ws->sparse_gy + k, side);
  }
  *s = TemplateRef{ws->sparse_tmpl, ws->sparse_gx, ws->sparse_gy, gradient_sums(ws->sparse_gx, ws->sparse_gy, side * side)};
  return textured(s->gs, side * side, options);
}

// The sparse grid's template of p in I sampled directly, without the dense template a cache would
// keep: the patch's odd rows whole (the samples and their horizontal neighbours) and its even rows
// at the odd columns (the vertical neighbours), the same samples and the same gradient formula
// as prepare_template then sparse_template, so the same floats. Only where the patch lies inside
// the image itself: -1 by the edges, margin or not (there the dense template's texture test has
// always decided, and a window textured on one grid only would be decided otherwise). Else 1 when that sparse template is textured, 0
// when not. Unlike the dense path it does not test the dense window's texture: a window textured
// on its sparse grid is used (a confirmation's template is used on that grid only).
int sparse_template_direct(const ImageView& I, const Eigen::Vector2f& p, const KltOptions& options, KltWorkspace* ws,
                           TemplateRef* s) {
  const int n = options.window_px, half = n / 2, ne = n + 2, side = half + 1;
  const PatchOrigin origin = patch_origin(p.x() - static_cast<float>(half + 1), p.y() - static_cast<float>(half + 1));
  const int x0 = origin.x0, y0 = origin.y0;
  const int cols = (ne + kChunk - 1) / kChunk * kChunk;
  // Bytes read past x0: the odd rows' chunks up to x0 + cols, the even rows' 16-byte chunks from
  // x0 + 1 up to x0 + 2 ceil8(side) (past the patch for n = 5, 17, 19, 21: still readable).
  const int last_byte = std::max(cols, 2 * ((side + kChunk - 1) / kChunk * kChunk));
  if (!(x0 >= 0 && x0 + last_byte < I.width && y0 >= 0 && y0 + ne < I.height)) return -1;
  const Weights& w = origin.w;
  const long stride = I.stride;
  // Rows 0, 2, ..., 2 side of the patch at its odd columns 1, 3, ..., 2 side - 1.
  alignas(16) Px even[(kMaxSparseSide + 1) * kMaxSparseCols];
  for (int j = 0; j <= side; ++j) {
    const std::uint8_t* r = I.row(y0 + 2 * j) + x0 + 1;
    for (int i = 0; i < side; i += kChunk)
      sample_chunk_step2<Px>(r + 2 * i, r + stride + 2 * i, w, even + j * kMaxSparseCols + i);
  }
  alignas(16) Px odd[kMaxSrcRow];
  for (int j = 0; j < side; ++j) {
    const std::uint8_t* r = I.row(y0 + 2 * j + 1) + x0;
    for (int i = 0; i < cols; i += kChunk) sample_chunk<Px>(r + i, r + stride + i, w, odd + i);
    const Px* above = even + j * kMaxSparseCols;
    const Px* below = above + kMaxSparseCols;
    Px* t = ws->sparse_tmpl + j * side;
    Px* gx = ws->sparse_gx + j * side;
    Px* gy = ws->sparse_gy + j * side;
    for (int i = 0; i < side; ++i) {
      t[i] = odd[2 * i + 1];
      gx[i] = static_cast<Px>(odd[2 * i + 2] - odd[2 * i]);
      gy[i] = static_cast<Px>(below[i] - above[i]);
    }
  }
  *s = TemplateRef{ws->sparse_tmpl, ws->sparse_gx, ws->sparse_gy, gradient_sums(ws->sparse_gx, ws->sparse_gy, side * side)};
  return textured(s->gs, side * side, options) ? 1 : 0;
}

// The window at top-left (x, y) on grid g, in 128 x grey levels.
void sample_window(const ImageView& J, float x, float y, const WindowGrid& g, Px* out) {
  if (g.step == 1) {
    sample_fixed<Px>(J, x, y, g.side, out);
  } else {
    sample_fixed_step2<Px>(J, x, y, g.side, out);
  }
}

// sample_window, then error_sums over the window, in one pass over its rows when a row is one
// vector step (the dense grid 9..16 samples wide, the sparse grid 8) and the sampler reads the
// image in place: the same samples into out and the same integer sums (exact in any order). The
// dense rows' sums take the row's n samples alone (the vector's last 16 - n lanes, the next
// row's, masked out); out and the template arrays are read and written up to 16 - n samples past
// the window, inside their spare lanes.
ErrorSums sample_error_sums(const ImageView& J, float x, float y, const WindowGrid& g, const TemplateRef& t, Px* out) {
#if defined(__ARM_NEON) || defined(__SSE2__)
  const int n = g.side;
  const PatchOrigin o = patch_origin(x, y);
  const long stride = J.stride;
  const std::uint8_t* r = J.row(std::max(o.y0, -J.margin)) + std::max(o.x0, -J.margin);
  if (g.step == 1 && n > kChunk && n <= 2 * kChunk && columns_readable(J, o.x0, 2 * kChunk + 1) &&
      rows_readable(J, o.y0, n + 1)) {
    ErrorLanes acc;
    for (int k = 0; k < n * n; k += n, r += stride) {
      SumVec lo, hi;
      chunk16_sums(r, r + stride, o.w, &lo, &hi);
      store_sums(lo, out + k);
      store_sums(hi, out + k + kChunk);
      acc.add(ErrorLanes::difference(t.tmpl + k, lo), t.gx + k, t.gy + k);
      acc.add(ErrorLanes::first_lanes(ErrorLanes::difference(t.tmpl + k + kChunk, hi), n - kChunk), t.gx + k + kChunk,
              t.gy + k + kChunk);
    }
    return acc.sums();
  }
  if (g.step == 2 && n == kChunk && columns_readable(J, o.x0, 2 * kChunk) && rows_readable(J, o.y0, 2 * n)) {
    ErrorLanes acc;
    for (int j = 0, k = 0; j < n; ++j, k += n) {  // row j's source rows by index, as sample_fixed_step2
      const SumVec s = chunk_step2_sums(r + 2 * j * stride, r + (2 * j + 1) * stride, o.w);
      store_sums(s, out + k);
      acc.add(ErrorLanes::difference(t.tmpl + k, s), t.gx + k, t.gy + k);
    }
    return acc.sums();
  }
#endif
  sample_window(J, x, y, g, out);
  return error_sums(t.tmpl, out, t.gx, t.gy, g.samples());
}

// Level `level`'s template of p_prev in prev (p: the same point in the level's pixels): read
// from the cache slot when it holds it, else sampled, into the slot when there is one. False
// when the window is untextured.
bool level_template(const ImagePyramid& prev, int level, const Eigen::Vector2f& p_prev, const Eigen::Vector2f& p,
                    const KltOptions& options, KltTemplateCache* cache, int slot, KltWorkspace* ws, TemplateRef* t) {
  bool filled = false;
  Px* blk = cache != nullptr ? cache->block(slot, prev, p_prev, level, &filled) : nullptr;
  if (blk == nullptr) {
    *t = TemplateRef{ws->tmpl, ws->gx, ws->gy, GradientSums{}};
    return prepare_template(prev.level(level), p, options, ws->tmpl_ext, t);
  }
  const int stride = template_stride(options.window_px);
  *t = TemplateRef{blk, blk + stride, blk + 2 * stride, GradientSums{}};
  Px* sums_at = blk + 3 * stride;  // the sums, then the usable flag (floats, by copy)
  float sums[kSumFloats];
  if (filled) {
    std::memcpy(sums, sums_at, sizeof sums);
    t->gs = GradientSums{sums[0], sums[1], sums[2], sums[3], sums[4]};
    return sums[5] != 0.0f;
  }
  const bool usable = prepare_template(prev.level(level), p, options, ws->tmpl_ext, t);
  const GradientSums& g = t->gs;
  sums[0] = g.gxx, sums[1] = g.gxy, sums[2] = g.gyy, sums[3] = g.gx, sums[4] = g.gy;
  sums[5] = usable ? 1.0f : 0.0f;
  sums[6] = sums[7] = 0.0f;
  std::memcpy(sums_at, sums, sizeof sums);
  cache->mark_filled(slot, level);
  return usable;
}

// Gauss-Newton iterations of one level from the carried displacement g: the flow nu on top of it.
// False when the window left J entirely or the flow ran farther than the window reaches (it has
// locked onto something else). *converged: the last update was below epsilon_px, so warped
// (sampled before it) is the window at the result to within epsilon_px.
bool iterate_level(const ImageView& J, const Eigen::Vector2f& p, const Eigen::Vector2f& g, const KltOptions& options,
                   float epsilon_px, const TemplateRef& t, const WindowGrid& grid, Px* warped, Eigen::Vector2f* nu,
                   bool* converged) {
  const int half = options.window_px / 2, nn = grid.samples();
  const float inv_area = 1.0f / static_cast<float>(nn);
  const GradientSums& gs = t.gs;
  const float inv_det = 1.0f / (gs.gxx * gs.gyy - gs.gxy * gs.gxy);
  nu->setZero();
  *converged = false;
  for (int it = 0; it < options.max_iterations; ++it) {
    const float qx = p.x() + g.x() + nu->x(), qy = p.y() + g.y() + nu->y();
    if (!(qx > -static_cast<float>(half) && qy > -static_cast<float>(half) &&
          qx < static_cast<float>(J.width + half) && qy < static_cast<float>(J.height + half))) {
      return false;
    }
    // Intensity offset between the windows (exposure, or the two cameras' gains) removed:
    // e = (T - mean T) - (J - mean J) = d - mean d with d = T - J, so
    // sum e g = sum d g - mean(d) sum g (d is small near convergence: no cancellation).
    const ErrorSums es = sample_error_sums(J, qx - static_cast<float>(half), qy - static_cast<float>(half), grid, t, warped);
    const float mean_d = es.d * inv_area;
    const float bx = es.dgx - mean_d * gs.gx;
    const float by = es.dgy - mean_d * gs.gy;
    const float ex = inv_det * (gs.gyy * bx - gs.gxy * by);
    const float ey = inv_det * (gs.gxx * by - gs.gxy * bx);
    nu->x() += ex;
    nu->y() += ey;
    if (ex * ex + ey * ey < epsilon_px * epsilon_px) {
      *converged = true;
      break;
    }
  }
  return nu->squaredNorm() <= static_cast<float>(half * half);
}

// The template level `level` iterates on, into *t: the sparse grid's (*sparse) or the whole
// window's. A sparse level whose template no cache keeps (the stereo confirmations': used once,
// on the sparse grid) samples that grid alone; the others sample (or read) the whole template
// and cut the sparse one from it. False when the level has no usable template.
bool iteration_template(const ImagePyramid& prev, int level, const Eigen::Vector2f& p_prev, const Eigen::Vector2f& p,
                        const KltOptions& options, KltTemplateCache* cache, int slot, KltWorkspace* ws, TemplateRef* t,
                        bool* sparse) {
  const bool want_sparse = level >= options.sparse_from_level;
  const bool uncached = cache == nullptr || slot < 0 || slot >= cache->slots() || level >= cache->levels();
  const int direct = want_sparse && uncached ? sparse_template_direct(prev.level(level), p, options, ws, t) : -1;
  *sparse = direct == 1;
  if (*sparse) return true;
  TemplateRef dense;
  if (!level_template(prev, level, p_prev, p, options, cache, slot, ws, &dense)) return false;
  // direct == 0: that sparse template is untextured, as the one cut from dense would be.
  *sparse = want_sparse && direct == -1 && sparse_template(dense, options.window_px, options, ws, t);
  if (!*sparse) *t = dense;
  return true;
}

}  // namespace

int klt_template_units(int window_px) { return 3 * template_stride(window_px) + kSumUnits; }

Status klt_track(const ImagePyramid& prev, const ImagePyramid& curr, int levels, const KltOptions& options,
                 const Eigen::Vector2f& p_prev, Eigen::Vector2f* p_curr, KltTemplateCache* cache, int slot) {
  KltWorkspace ws;
  const int half = options.window_px / 2;
  levels = std::min({levels, prev.levels(), curr.levels()});
  if (levels < 1 || !std::isfinite(p_curr->x()) || !std::isfinite(p_curr->y())) return Status::kNotConverged;

  const float top_scale = 1.0f / static_cast<float>(1 << (levels - 1));
  // Displacement (guess + flow) carried from level to level, in the current level's pixels.
  Eigen::Vector2f g = (*p_curr - p_prev) * top_scale;
  bool converged = false;
  TemplateRef t;
  const WindowGrid dense_grid{options.window_px, 1}, sparse_grid{half + 1, 2};
  WindowGrid grid = dense_grid;
  for (int level = levels - 1; level >= 0; --level) {
    const Eigen::Vector2f p = p_prev * (1.0f / static_cast<float>(1 << level));
    // A coarse level that cannot be used (blurred flat, or mostly outside a small image) is
    // skipped: the finer levels still refine the carried displacement. Level 0 must succeed.
    bool sparse = false;
    if (!iteration_template(prev, level, p_prev, p, options, cache, slot, &ws, &t, &sparse)) {
      if (level == 0) return Status::kNotConverged;
      g *= 2.0f;
      continue;
    }
    grid = sparse ? sparse_grid : dense_grid;
    Eigen::Vector2f nu;
    if (!iterate_level(curr.level(level), p, g, options, level == 0 ? options.epsilon_px : options.coarse_epsilon_px, t,
                       grid, ws.warped, &nu, &converged)) {
      if (level == 0) return Status::kNotConverged;
      nu.setZero();
    }
    g = level > 0 ? Eigen::Vector2f(2.0f * (g + nu)) : Eigen::Vector2f(g + nu);
  }
  const Eigen::Vector2f result = p_prev + g;
  const ImageView& J0 = curr.level(0);
  if (!(result.x() >= 0.0f && result.y() >= 0.0f && result.x() <= static_cast<float>(J0.width - 1) &&
        result.y() <= static_cast<float>(J0.height - 1))) {
    return Status::kNotConverged;
  }
  // Photometric check at level 0 (the template was sampled at level 0 in the last pass), on the
  // last iteration's window when it is within epsilon_px of the result.
  if (!converged) {
    sample_window(J0, result.x() - static_cast<float>(half), result.y() - static_cast<float>(half), grid, ws.warped);
  }
  // In 128 x grey levels, as the samples; on level 0's grid.
  if (!(mean_abs_error(t.tmpl, ws.warped, grid.samples()) <= options.max_mean_abs_error * static_cast<float>(kWeightOne))) {
    return Status::kNotConverged;
  }
  *p_curr = result;
  return Status::kOk;
}

}  // namespace ums
