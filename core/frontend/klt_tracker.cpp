#include "core/frontend/klt_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "core/frontend/float_lanes.hpp"

#if defined(__SSE2__)
#include <emmintrin.h>
#elif defined(__ARM_NEON)
#include <arm_neon.h>
#endif

namespace ums {

namespace {

// Window sums in 4 lanes (one SSE or NEON register) with a fixed order: element k always lands in
// lane k % 4 and the lanes are added 0..3, then the tail. Every machine then gives the same float
// (Eigen's reductions split differently per architecture; issue 8's cross-architecture check).
using Lanes = FloatLanes;
constexpr int kLanes = kFloatLanes;

inline float lane_sum(Lanes v) {
  float s = 0.0f;
  for (int i = 0; i < kLanes; ++i) s += v[i];
  return s;
}

// Structure tensor of the template gradients and their plain sums.
struct GradientSums {
  float gxx = 0.0f, gxy = 0.0f, gyy = 0.0f, gx = 0.0f, gy = 0.0f;
};

GradientSums gradient_sums(const float* gx, const float* gy, int nn) {
  Lanes sxx{}, sxy{}, syy{}, sx{}, sy{};
  int k = 0;
#pragma GCC unroll 4
  for (; k + kLanes <= nn; k += kLanes) {
    const Lanes a = load_lanes(gx + k), b = load_lanes(gy + k);
    sxx += a * a;
    sxy += a * b;
    syy += b * b;
    sx += a;
    sy += b;
  }
  GradientSums s{lane_sum(sxx), lane_sum(sxy), lane_sum(syy), lane_sum(sx), lane_sum(sy)};
  for (; k < nn; ++k) {
    s.gxx += gx[k] * gx[k];
    s.gxy += gx[k] * gy[k];
    s.gyy += gy[k] * gy[k];
    s.gx += gx[k];
    s.gy += gy[k];
  }
  return s;
}

// sum d, sum d gx, sum d gy with d = T - W.
struct ErrorSums {
  float d = 0.0f, dgx = 0.0f, dgy = 0.0f;
};

ErrorSums error_sums(const float* t, const float* w, const float* gx, const float* gy, int nn) {
  Lanes sd{}, sdx{}, sdy{};
  int k = 0;
  // Unrolled (the same sums in the same order): the loop's own add, compare and branch were a
  // quarter of the instructions of a 4-lane step.
#pragma GCC unroll 4
  for (; k + kLanes <= nn; k += kLanes) {
    const Lanes d = load_lanes(t + k) - load_lanes(w + k);
    sd += d;
    sdx += d * load_lanes(gx + k);
    sdy += d * load_lanes(gy + k);
  }
  ErrorSums s{lane_sum(sd), lane_sum(sdx), lane_sum(sdy)};
  for (; k < nn; ++k) {
    const float d = t[k] - w[k];
    s.d += d;
    s.dgx += d * gx[k];
    s.dgy += d * gy[k];
  }
  return s;
}

// Mean |T - W - offset| with the offset the mean of T - W.
float mean_abs_error(const float* t, const float* w, int nn) {
  Lanes sd{};
  int k = 0;
#pragma GCC unroll 4
  for (; k + kLanes <= nn; k += kLanes) sd += load_lanes(t + k) - load_lanes(w + k);
  float sum_d = lane_sum(sd);
  for (int j = k; j < nn; ++j) sum_d += t[j] - w[j];
  const float inv_area = 1.0f / static_cast<float>(nn);
  const float mean_d = sum_d * inv_area;
  const Lanes mean{mean_d, mean_d, mean_d, mean_d};
  Lanes sa{};
#pragma GCC unroll 4
  for (k = 0; k + kLanes <= nn; k += kLanes) {
    const Lanes e = load_lanes(t + k) - load_lanes(w + k) - mean;
    sa += e < 0.0f ? -e : e;
  }
  float sum_abs = lane_sum(sa);
  for (; k < nn; ++k) sum_abs += std::fabs(t[k] - w[k] - mean_d);
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

// 8 integer sums of pixel x weight (below 2^15) out as floats: grey levels (kGrey), or the sums.
#if defined(__ARM_NEON)
template <bool kGrey>
inline void store_sums(uint16x8_t s, float* out) {
  float32x4_t lo = vcvtq_f32_u32(vmovl_u16(vget_low_u16(s))), hi = vcvtq_f32_u32(vmovl_u16(vget_high_u16(s)));
  if constexpr (kGrey) {
    lo = vmulq_n_f32(lo, 1.0f / static_cast<float>(kWeightOne));
    hi = vmulq_n_f32(hi, 1.0f / static_cast<float>(kWeightOne));
  }
  vst1q_f32(out, lo);
  vst1q_f32(out + 4, hi);
}
#elif defined(__SSE2__)
template <bool kGrey>
inline void store_sums(__m128i s, float* out) {
  const __m128i zero = _mm_setzero_si128();
  __m128 lo = _mm_cvtepi32_ps(_mm_unpacklo_epi16(s, zero)), hi = _mm_cvtepi32_ps(_mm_unpackhi_epi16(s, zero));
  if constexpr (kGrey) {
    lo = _mm_mul_ps(lo, _mm_set1_ps(1.0f / static_cast<float>(kWeightOne)));
    hi = _mm_mul_ps(hi, _mm_set1_ps(1.0f / static_cast<float>(kWeightOne)));
  }
  _mm_storeu_ps(out, lo);
  _mm_storeu_ps(out + 4, hi);
}
#endif

// 8 samples from two source rows (each read at i .. i + 8, 9 pixels) as floats: grey levels, or
// (kGrey false) 128 times them, the integer sums themselves. The tracker works on the latter: a
// power-of-two scale changes no rounding, so only its two thresholds are scaled to match.
template <bool kGrey>
inline void sample_chunk(const std::uint8_t* r0, const std::uint8_t* r1, const Weights& w, float* out) {
#if defined(__ARM_NEON)
  uint16x8_t s = vmull_u8(vld1_u8(r0), vdup_n_u8(static_cast<std::uint8_t>(w.w00)));
  s = vmlal_u8(s, vld1_u8(r0 + 1), vdup_n_u8(static_cast<std::uint8_t>(w.w01)));
  s = vmlal_u8(s, vld1_u8(r1), vdup_n_u8(static_cast<std::uint8_t>(w.w10)));
  s = vmlal_u8(s, vld1_u8(r1 + 1), vdup_n_u8(static_cast<std::uint8_t>(w.w11)));
  store_sums<kGrey>(s, out);
#elif defined(__SSE2__)
  const __m128i zero = _mm_setzero_si128();
  auto px = [zero](const std::uint8_t* p) {
    return _mm_unpacklo_epi8(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)), zero);
  };
  // Products and sums below 2^15: 16-bit lanes hold them exactly.
  __m128i s = _mm_mullo_epi16(px(r0), _mm_set1_epi16(static_cast<short>(w.w00)));
  s = _mm_add_epi16(s, _mm_mullo_epi16(px(r0 + 1), _mm_set1_epi16(static_cast<short>(w.w01))));
  s = _mm_add_epi16(s, _mm_mullo_epi16(px(r1), _mm_set1_epi16(static_cast<short>(w.w10))));
  s = _mm_add_epi16(s, _mm_mullo_epi16(px(r1 + 1), _mm_set1_epi16(static_cast<short>(w.w11))));
  store_sums<kGrey>(s, out);
#else
  constexpr float kInv = kGrey ? 1.0f / static_cast<float>(kWeightOne) : 1.0f;
  for (int i = 0; i < kChunk; ++i) {
    const int v = w.w00 * r0[i] + w.w01 * r0[i + 1] + w.w10 * r1[i] + w.w11 * r1[i + 1];
    out[i] = static_cast<float>(v) * kInv;
  }
#endif
}

// The widest source row: the largest patch (window + 2) in whole chunks, plus the right neighbour.
constexpr int kMaxSrcRow = (KltOptions::kMaxWindowPx + 2 + kChunk - 1) / kChunk * kChunk + 1;
constexpr int kMaxSrcRows = KltOptions::kMaxWindowPx + 3;
// The sparse window: every other pixel of the window, window_px / 2 + 1 samples a side.
constexpr int kMaxSparseSide = KltOptions::kMaxWindowPx / 2 + 1;
constexpr int kMaxSparseCols = (kMaxSparseSide + kChunk - 1) / kChunk * kChunk;  // samples, whole chunks
constexpr int kMaxSparseSrcRow = 2 * kMaxSparseCols;                                 // bytes a row reads
static_assert(2 * kMaxSparseSide <= kMaxSrcRows, "the sparse sampler reads two source rows per sample row");

// Source pixels x0 .. x0 + src - 1 of row r (width w), the ones outside the row repeating its
// end pixels.
void clamped_row(const std::uint8_t* r, int w, int x0, int src, std::uint8_t* out) {
  const int lo = std::clamp(-x0, 0, src);       // first i inside the row
  const int hi = std::clamp(w - x0, lo, src);   // one past the last i inside
  std::memset(out, r[0], static_cast<std::size_t>(lo));
  if (hi > lo) std::memcpy(out + lo, r + x0 + lo, static_cast<std::size_t>(hi - lo));
  std::memset(out + hi, r[w - 1], static_cast<std::size_t>(src - hi));
}

// sample_patch_bilinear's contract (n checked by the caller; kGrey false: 128 times the grey
// levels). The pixels are read in place when the columns under the patch (whole chunks + 1) lie
// inside the image; a block that crosses the left or right edge is copied with the border pixels
// repeated.
template <bool kGrey>
void sample_fixed(const ImageView& image, float x, float y, int n, float* out) {
  const PatchOrigin origin = patch_origin(x, y);
  const int x0 = origin.x0, y0 = origin.y0;
  const Weights& w = origin.w;
  const int cols = (n + kChunk - 1) / kChunk * kChunk;
  const int src = cols + 1;
  alignas(16) float scratch[kMaxSrcRow];
  const bool inside = x0 >= 0 && x0 + src <= image.width;
  if (inside && y0 >= 0 && y0 + n < image.height) {
    // The common case, away from every edge: the source rows in place, walked by stride. Rows
    // in whole chunks as below; only the last rows, whose chunks would run past the patch, go
    // through the scratch row.
    const long stride = image.stride;
    const std::uint8_t* r = image.row(y0) + x0;
    const int direct = std::min(n, n * n >= cols ? (n * n - cols) / n + 1 : 0);
    int j = 0;
    for (; j < direct; ++j, r += stride)
      for (int i = 0; i < cols; i += kChunk) sample_chunk<kGrey>(r + i, r + stride + i, w, out + j * n + i);
    for (; j < n; ++j, r += stride) {
      for (int i = 0; i < cols; i += kChunk) sample_chunk<kGrey>(r + i, r + stride + i, w, scratch + i);
      std::memcpy(out + j * n, scratch, sizeof(float) * static_cast<std::size_t>(n));
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
  // Each row in whole chunks: the samples past n land on the next row's start, which that row
  // overwrites; a row whose chunks would run past the patch goes through a scratch row.
  for (int j = 0; j < n; ++j) {
    float* o = j * n + cols <= n * n ? out + j * n : scratch;
    for (int i = 0; i < cols; i += kChunk) sample_chunk<kGrey>(rows[j] + i, rows[j + 1] + i, w, o + i);
    if (o == scratch) std::memcpy(out + j * n, scratch, sizeof(float) * static_cast<std::size_t>(n));
  }
}

// 8 samples two pixels apart, each from pixels 2i and 2i + 1 of the two source rows (16 bytes
// read from each): the same integer formula as sample_chunk, on the even and odd pixels.
template <bool kGrey>
inline void sample_chunk_step2(const std::uint8_t* r0, const std::uint8_t* r1, const Weights& w, float* out) {
#if defined(__ARM_NEON)
  const uint8x8x2_t a = vld2_u8(r0), b = vld2_u8(r1);  // val[0]: pixels 2i, val[1]: 2i + 1
  uint16x8_t s = vmull_u8(a.val[0], vdup_n_u8(static_cast<std::uint8_t>(w.w00)));
  s = vmlal_u8(s, a.val[1], vdup_n_u8(static_cast<std::uint8_t>(w.w01)));
  s = vmlal_u8(s, b.val[0], vdup_n_u8(static_cast<std::uint8_t>(w.w10)));
  s = vmlal_u8(s, b.val[1], vdup_n_u8(static_cast<std::uint8_t>(w.w11)));
  store_sums<kGrey>(s, out);
#elif defined(__SSE2__)
  const __m128i low_bytes = _mm_set1_epi16(0x00FF);
  const __m128i a = _mm_loadu_si128(reinterpret_cast<const __m128i*>(r0));
  const __m128i b = _mm_loadu_si128(reinterpret_cast<const __m128i*>(r1));
  // 16-bit lanes: the low byte is pixel 2i, the high byte pixel 2i + 1.
  __m128i s = _mm_mullo_epi16(_mm_and_si128(a, low_bytes), _mm_set1_epi16(static_cast<short>(w.w00)));
  s = _mm_add_epi16(s, _mm_mullo_epi16(_mm_srli_epi16(a, 8), _mm_set1_epi16(static_cast<short>(w.w01))));
  s = _mm_add_epi16(s, _mm_mullo_epi16(_mm_and_si128(b, low_bytes), _mm_set1_epi16(static_cast<short>(w.w10))));
  s = _mm_add_epi16(s, _mm_mullo_epi16(_mm_srli_epi16(b, 8), _mm_set1_epi16(static_cast<short>(w.w11))));
  store_sums<kGrey>(s, out);
#else
  constexpr float kInv = kGrey ? 1.0f / static_cast<float>(kWeightOne) : 1.0f;
  for (int i = 0; i < kChunk; ++i) {
    const int v = w.w00 * r0[2 * i] + w.w01 * r0[2 * i + 1] + w.w10 * r1[2 * i] + w.w11 * r1[2 * i + 1];
    out[i] = static_cast<float>(v) * kInv;
  }
#endif
}

// sample_sparse_bilinear's contract (kGrey false: 128 times the grey levels): the samples of
// sample_fixed's (2n - 1)-wide patch at (x, y) on its even rows and columns (the same weights). In
// place when the source block (whole chunks of 16 pixels) lies inside the image, else from copied
// rows with the border pixels repeated.
template <bool kGrey>
void sample_fixed_step2(const ImageView& image, float x, float y, int n, float* out) {
  const PatchOrigin origin = patch_origin(x, y);
  const int x0 = origin.x0, y0 = origin.y0;
  const Weights& w = origin.w;
  const int cols = (n + kChunk - 1) / kChunk * kChunk;
  const int src = 2 * cols;
  const std::uint8_t* rows[kMaxSrcRows];
  std::uint8_t copy[kMaxSrcRows][kMaxSparseSrcRow];
  const int ymax = image.height - 1;
  const bool inside = x0 >= 0 && x0 + src <= image.width;
  if (inside && y0 >= 0 && y0 + 2 * n <= image.height && n % kChunk == 0) {
    // The common case (window_px 15: one chunk per row), away from the image edges: the source
    // rows in place, walked by stride.
    const long stride = image.stride;
    for (int j = 0; j < n; ++j) {
      const std::uint8_t* r = image.row(y0 + 2 * j) + x0;
      for (int i = 0; i < n; i += kChunk) sample_chunk_step2<kGrey>(r + 2 * i, r + stride + 2 * i, w, out + j * n + i);
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
  alignas(16) float scratch[kMaxSparseCols];
  for (int j = 0; j < n; ++j) {
    float* o = j * n + cols <= n * n ? out + j * n : scratch;
    for (int i = 0; i < cols; i += kChunk)
      sample_chunk_step2<kGrey>(rows[2 * j] + 2 * i, rows[2 * j + 1] + 2 * i, w, o + i);
    if (o == scratch) std::memcpy(out + j * n, scratch, sizeof(float) * static_cast<std::size_t>(n));
  }
}

void check_patch_size(int n) {
  if (n < 1 || n > KltOptions::kMaxWindowPx + 2) {
    throw std::invalid_argument("sample_patch_bilinear: n must be in 1.." + std::to_string(KltOptions::kMaxWindowPx + 2) +
                                ", got " + std::to_string(n));
  }
}

// The n x n template (the centre of the (n + 2)^2 patch ext) and its central-difference
// gradients, row by row in whole 4-lane vectors: the lanes past n land on the next row's start,
// which that row overwrites, and past the last row in the arrays' kLanes of padding (ext, too, is
// read up to kLanes past its end). Element by element as the scalar formula: the same floats.
void template_and_gradients(const float* ext, int n, float* tmpl, float* gx, float* gy) {
  const int ne = n + 2;
  const int cols = (n + kLanes - 1) / kLanes * kLanes;
  const Lanes half{0.5f, 0.5f, 0.5f, 0.5f};
  for (int j = 0; j < n; ++j) {
    const float* c = ext + (j + 1) * ne + 1;
    const int k0 = j * n;
    for (int i = 0; i < cols; i += kLanes) {
      store_lanes(tmpl + k0 + i, load_lanes(c + i));
      store_lanes(gx + k0 + i, half * (load_lanes(c + i + 1) - load_lanes(c + i - 1)));
      store_lanes(gy + k0 + i, half * (load_lanes(c + i + ne) - load_lanes(c + i - ne)));
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
  sample_fixed<true>(image, x, y, n, out);
}

void sample_sparse_bilinear(const ImageView& image, float x, float y, int n, float* out) {
  if (n < 1 || n > kMaxSparseSide) {
    throw std::invalid_argument("sample_sparse_bilinear: n must be in 1.." + std::to_string(kMaxSparseSide) + ", got " +
                                std::to_string(n));
  }
  sample_fixed_step2<true>(image, x, y, n, out);
}

namespace {

// One klt_track call's buffers: the patch a template is cut from, a template with its gradients
// when no cache keeps it, and the warped window (stack, no allocation).
struct KltWorkspace {
  static constexpr int kMaxN = KltOptions::kMaxWindowPx;
  static constexpr int kMaxT = kMaxN + 2;
  // + kLanes: template_and_gradients reads and writes whole vectors past the last row's end.
  alignas(16) float tmpl_ext[kMaxT * kMaxT + kLanes];
  alignas(16) float tmpl[kMaxN * kMaxN + kLanes];
  alignas(16) float gx[kMaxN * kMaxN + kLanes];
  alignas(16) float gy[kMaxN * kMaxN + kLanes];
  alignas(16) float warped[kMaxN * kMaxN];
  // A sparse level's template: every other sample of the (dense) template, and its gradients.
  alignas(16) float sparse_tmpl[kMaxSparseSide * kMaxSparseSide + kLanes];
  alignas(16) float sparse_gx[kMaxSparseSide * kMaxSparseSide + kLanes];
  alignas(16) float sparse_gy[kMaxSparseSide * kMaxSparseSide + kLanes];
};

// A level's template, in the workspace or in a cache block.
struct TemplateRef {
  float* tmpl = nullptr;
  float* gx = nullptr;
  float* gy = nullptr;
  GradientSums gs;
};

// Floats of each array in a cache block, whole vectors with kLanes to spare (as the workspace).
constexpr int template_stride(int n) { return (n * n + 2 * kLanes - 1) / kLanes * kLanes; }

// even_samples' last read of a template (last sparse row, last group of 4) lies inside the
// template_stride(n) floats of a cache block and the workspace's arrays, for every odd window.
constexpr bool sparse_reads_fit() {
  for (int n = 1; n <= KltOptions::kMaxWindowPx; n += 2) {
    const int side = n / 2 + 1, groups = (side + kLanes - 1) / kLanes * kLanes;
    const int last = 2 * (side - 1) * n + 2 * groups - 1;
    if (last >= template_stride(n) || last >= KltOptions::kMaxWindowPx * KltOptions::kMaxWindowPx + kLanes) return false;
  }
  return true;
}
static_assert(sparse_reads_fit(), "even_samples reads past a template's storage");

// A cache block: template, gradients, then the sums and the usable flag.
constexpr int kSumFloats = 8;

// The smallest eigenvalue of the mean structure tensor is at least min_eigen (the samples are
// 128 x grey levels, sample_chunk: the tensor is 128^2 x (grey/px)^2).
bool textured(const GradientSums& gs, int samples, const KltOptions& options) {
  const float inv_area = 1.0f / static_cast<float>(samples);
  const float a = gs.gxx * inv_area, b = gs.gxy * inv_area, c2 = gs.gyy * inv_area;
  const float min_eig = 0.5f * ((a + c2) - std::sqrt((a - c2) * (a - c2) + 4.0f * b * b));
  constexpr float kScale2 = static_cast<float>(kWeightOne * kWeightOne);
  return min_eig >= options.min_eigen * kScale2 && min_eig > 0.0f;
}

// Samples the template around p in I and its gradients into t (arrays of n * n + kLanes floats).
// False when the window is untextured: the smallest eigenvalue of the mean structure tensor is
// below min_eigen.
bool prepare_template(const ImageView& I, const Eigen::Vector2f& p, const KltOptions& options, float* tmpl_ext,
                      TemplateRef* t) {
  const int n = options.window_px, half = n / 2, ne = n + 2, nn = n * n;
  sample_fixed<false>(I, p.x() - static_cast<float>(half + 1), p.y() - static_cast<float>(half + 1), ne, tmpl_ext);
  std::fill(tmpl_ext + ne * ne, tmpl_ext + ne * ne + kLanes, 0.0f);  // read by the last row's spare lanes
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

// dst[i] = src[2 i] for i < count, 4 at a time: reads src up to src[2 c - 1] and writes dst up
// to dst[c - 1], c = count rounded up to 4. A template's last sparse row then reads up to 6
// floats past the template (n = 9, 17, 25; sparse_reads_fit below checks every window), into
// lanes that are dropped, and writes into the next sparse row, which comes after it, or the
// sparse arrays' spare lanes.
inline void even_samples(const float* src, float* dst, int count) {
  for (int i = 0; i < count; i += kLanes, src += 2 * kLanes, dst += kLanes) {
#if defined(__SSE2__)
    _mm_storeu_ps(dst, _mm_shuffle_ps(_mm_loadu_ps(src), _mm_loadu_ps(src + 4), _MM_SHUFFLE(2, 0, 2, 0)));
#elif defined(__ARM_NEON)
    vst1q_f32(dst, vld2q_f32(src).val[0]);
#else
    for (int k = 0; k < kLanes; ++k) dst[k] = src[2 * k];
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
// as prepare_template then sparse_template, so the same floats. Only away from the image edges
// (where sample_fixed reads in place): -1 there. Else 1 when that sparse template is textured, 0
// when not. Unlike the dense path it does not test the dense window's texture: a window textured
// on its sparse grid is used (a confirmation's template is used on that grid only).
int sparse_template_direct(const ImageView& I, const Eigen::Vector2f& p, const KltOptions& options, KltWorkspace* ws,
                           TemplateRef* s) {
  const int n = options.window_px, half = n / 2, ne = n + 2, side = half + 1;
  const PatchOrigin origin = patch_origin(p.x() - static_cast<float>(half + 1), p.y() - static_cast<float>(half + 1));
  const int x0 = origin.x0, y0 = origin.y0;
  const int cols = (ne + kChunk - 1) / kChunk * kChunk;
  // Bytes read past x0: the odd rows' chunks up to x0 + cols, the even rows' 16-byte chunks from
  // x0 + 1 up to x0 + 2 ceil8(side) (past the patch for n = 5, 17, 19, 21: still inside the image).
  const int last_byte = std::max(cols, 2 * ((side + kChunk - 1) / kChunk * kChunk));
  if (!(x0 >= 0 && x0 + last_byte < I.width && y0 >= 0 && y0 + ne < I.height)) return -1;
  const Weights& w = origin.w;
  const long stride = I.stride;
  // Rows 0, 2, ..., 2 side of the patch at its odd columns 1, 3, ..., 2 side - 1.
  alignas(16) float even[(kMaxSparseSide + 1) * kMaxSparseCols];
  for (int j = 0; j <= side; ++j) {
    const std::uint8_t* r = I.row(y0 + 2 * j) + x0 + 1;
    for (int i = 0; i < side; i += kChunk)
      sample_chunk_step2<false>(r + 2 * i, r + stride + 2 * i, w, even + j * kMaxSparseCols + i);
  }
  alignas(16) float odd[kMaxSrcRow];
  for (int j = 0; j < side; ++j) {
    const std::uint8_t* r = I.row(y0 + 2 * j + 1) + x0;
    for (int i = 0; i < cols; i += kChunk) sample_chunk<false>(r + i, r + stride + i, w, odd + i);
    const float* above = even + j * kMaxSparseCols;
    const float* below = above + kMaxSparseCols;
    float* t = ws->sparse_tmpl + j * side;
    float* gx = ws->sparse_gx + j * side;
    float* gy = ws->sparse_gy + j * side;
    for (int i = 0; i < side; ++i) {
      t[i] = odd[2 * i + 1];
      gx[i] = 0.5f * (odd[2 * i + 2] - odd[2 * i]);
      gy[i] = 0.5f * (below[i] - above[i]);
    }
  }
  *s = TemplateRef{ws->sparse_tmpl, ws->sparse_gx, ws->sparse_gy, gradient_sums(ws->sparse_gx, ws->sparse_gy, side * side)};
  return textured(s->gs, side * side, options) ? 1 : 0;
}

// The window at top-left (x, y) on grid g, in 128 x grey levels.
void sample_window(const ImageView& J, float x, float y, const WindowGrid& g, float* out) {
  if (g.step == 1) {
    sample_fixed<false>(J, x, y, g.side, out);
  } else {
    sample_fixed_step2<false>(J, x, y, g.side, out);
  }
}

// Level `level`'s template of p_prev in prev (p: the same point in the level's pixels): read
// from the cache slot when it holds it, else sampled, into the slot when there is one. False
// when the window is untextured.
bool level_template(const ImagePyramid& prev, int level, const Eigen::Vector2f& p_prev, const Eigen::Vector2f& p,
                    const KltOptions& options, KltTemplateCache* cache, int slot, KltWorkspace* ws, TemplateRef* t) {
  bool filled = false;
  float* blk = cache != nullptr ? cache->block(slot, prev, p_prev, level, &filled) : nullptr;
  if (blk == nullptr) {
    *t = TemplateRef{ws->tmpl, ws->gx, ws->gy, GradientSums{}};
    return prepare_template(prev.level(level), p, options, ws->tmpl_ext, t);
  }
  const int stride = template_stride(options.window_px);
  *t = TemplateRef{blk, blk + stride, blk + 2 * stride, GradientSums{}};
  float* sums = blk + 3 * stride;  // the sums, then the usable flag
  if (filled) {
    t->gs = GradientSums{sums[0], sums[1], sums[2], sums[3], sums[4]};
    return sums[5] != 0.0f;
  }
  const bool usable = prepare_template(prev.level(level), p, options, ws->tmpl_ext, t);
  const GradientSums& g = t->gs;
  sums[0] = g.gxx, sums[1] = g.gxy, sums[2] = g.gyy, sums[3] = g.gx, sums[4] = g.gy;
  sums[5] = usable ? 1.0f : 0.0f;
  cache->mark_filled(slot, level);
  return usable;
}

// Gauss-Newton iterations of one level from the carried displacement g: the flow nu on top of it.
// False when the window left J entirely or the flow ran farther than the window reaches (it has
// locked onto something else). *converged: the last update was below epsilon_px, so warped
// (sampled before it) is the window at the result to within epsilon_px.
bool iterate_level(const ImageView& J, const Eigen::Vector2f& p, const Eigen::Vector2f& g, const KltOptions& options,
                   float epsilon_px, const TemplateRef& t, const WindowGrid& grid, float* warped, Eigen::Vector2f* nu,
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
    sample_window(J, qx - static_cast<float>(half), qy - static_cast<float>(half), grid, warped);
    // Intensity offset between the windows (exposure, or the two cameras' gains) removed:
    // e = (T - mean T) - (J - mean J) = d - mean d with d = T - J, so
    // sum e g = sum d g - mean(d) sum g (d is small near convergence: no cancellation).
    const ErrorSums es = error_sums(t.tmpl, warped, t.gx, t.gy, nn);
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

int klt_template_floats(int window_px) { return 3 * template_stride(window_px) + kSumFloats; }

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
