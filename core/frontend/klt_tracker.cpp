#include "core/frontend/klt_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

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
typedef float Lanes __attribute__((vector_size(16)));
constexpr int kLanes = 4;

inline Lanes load(const float* p) {
  Lanes v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

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
  for (; k + kLanes <= nn; k += kLanes) {
    const Lanes a = load(gx + k), b = load(gy + k);
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
  for (; k + kLanes <= nn; k += kLanes) {
    const Lanes d = load(t + k) - load(w + k);
    sd += d;
    sdx += d * load(gx + k);
    sdy += d * load(gy + k);
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
  for (; k + kLanes <= nn; k += kLanes) sd += load(t + k) - load(w + k);
  float sum_d = lane_sum(sd);
  for (int j = k; j < nn; ++j) sum_d += t[j] - w[j];
  const float inv_area = 1.0f / static_cast<float>(nn);
  const float mean_d = sum_d * inv_area;
  const Lanes mean{mean_d, mean_d, mean_d, mean_d};
  Lanes sa{};
  for (k = 0; k + kLanes <= nn; k += kLanes) {
    const Lanes e = load(t + k) - load(w + k) - mean;
    sa += e < 0.0f ? -e : e;
  }
  float sum_abs = lane_sum(sa);
  for (; k < nn; ++k) sum_abs += std::fabs(t[k] - w[k] - mean_d);
  return sum_abs * inv_area;
}


// 8 pixels -> 8 floats (exact: the values are small integers), as two 4-lane vectors.
constexpr int kWiden = 8;
inline void widen8(const std::uint8_t* p, float* out) {
#if defined(__SSE2__)
  const __m128i zero = _mm_setzero_si128();
  const __m128i w = _mm_unpacklo_epi8(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)), zero);
  _mm_storeu_ps(out, _mm_cvtepi32_ps(_mm_unpacklo_epi16(w, zero)));
  _mm_storeu_ps(out + 4, _mm_cvtepi32_ps(_mm_unpackhi_epi16(w, zero)));
#elif defined(__ARM_NEON)
  const uint16x8_t w = vmovl_u8(vld1_u8(p));
  vst1q_f32(out, vcvtq_f32_u32(vmovl_u16(vget_low_u16(w))));
  vst1q_f32(out + 4, vcvtq_f32_u32(vmovl_u16(vget_high_u16(w))));
#else
  for (int i = 0; i < kWiden; ++i) out[i] = static_cast<float>(p[i]);
#endif
}

inline void store(float* p, Lanes v) { std::memcpy(p, &v, sizeof v); }

// The largest source row converted: window + 2 (the template with its gradient border), rounded
// up to whole vectors, plus the right neighbour, rounded up to whole 8-pixel loads.
constexpr int kMaxSrcRow = ((KltOptions::kMaxWindowPx + 2 + kLanes - 1) / kLanes * kLanes + 1 + kWiden - 1) / kWiden * kWiden;
constexpr int kMaxSrcRows = KltOptions::kMaxWindowPx + 3;

// Source pixels x0 .. x0 + src - 1 of row y (clamped into the image) as floats, 8 at a time
// inside the image. A row that crosses the left or right border (often on the small coarse
// levels) repeats the border pixel outside and converts the part inside 8 at a time while
// whole loads stay inside the row.
void convert_row(const ImageView& image, int x0, int y, int src, float* f) {
  const std::uint8_t* r = image.row(std::clamp(y, 0, image.height - 1));
  if (x0 >= 0 && x0 + src <= image.width) {
    for (int i = 0; i < src; i += kWiden) widen8(r + x0 + i, f + i);
    return;
  }
  const int lo = std::clamp(-x0, 0, src);               // first i inside the image
  const int hi = std::clamp(image.width - x0, lo, src);  // one past the last i inside
  const float left = static_cast<float>(r[0]), right = static_cast<float>(r[image.width - 1]);
  int i = 0;
  for (; i < lo; ++i) f[i] = left;
  for (; i + kWiden <= hi; i += kWiden) widen8(r + x0 + i, f + i);
  for (; i < hi; ++i) f[i] = static_cast<float>(r[x0 + i]);
  for (; i < src; ++i) f[i] = right;
}

// Bilinear patches from the pixels under them, converted to float once per integer origin: the
// iterations of one KLT level mostly move the window by less than a pixel and reuse them.
class SourceBlock {
 public:
  // sample_patch_bilinear's contract (n checked by the caller).
  void sample(const ImageView& image, float x, float y, int n, float* out) {
    const float fx0 = std::floor(x), fy0 = std::floor(y);
    const int x0 = static_cast<int>(fx0), y0 = static_cast<int>(fy0);
    const float ax = x - fx0, ay = y - fy0;
    // One fraction for the whole patch: four weights, reused for every sample.
    const float w00 = (1.0f - ax) * (1.0f - ay), w01 = ax * (1.0f - ay), w10 = (1.0f - ax) * ay, w11 = ax * ay;
    const int cols = (n + kLanes - 1) / kLanes * kLanes;
    if (image.data != data_ || image.stride != stride_ || x0 != x0_ || y0 != y0_ || n != n_) {
      const int src = (cols + 1 + kWiden - 1) / kWiden * kWiden;
      for (int j = 0; j <= n; ++j) convert_row(image, x0, y0 + j, src, rows_[j]);
      data_ = image.data;
      stride_ = image.stride;
      x0_ = x0;
      y0_ = y0;
      n_ = n;
    }
    interpolate(n, cols, Lanes{w00, w00, w00, w00}, Lanes{w01, w01, w01, w01}, Lanes{w10, w10, w10, w10},
                Lanes{w11, w11, w11, w11}, out);
  }

 private:
  // Each output row in whole 4-lane vectors: the samples past n land on the next row's start,
  // which that row overwrites; the last row goes through a scratch row. The products and their
  // order are the scalar formula's, w00 p00 + w01 p01 + w10 p10 + w11 p11: the same floats on
  // every machine.
  void interpolate(int n, int cols, Lanes w00, Lanes w01, Lanes w10, Lanes w11, float* out) const {
    alignas(16) float last[kMaxSrcRow];
    for (int j = 0; j < n; ++j) {
      const float* f0 = rows_[j];
      const float* f1 = rows_[j + 1];
      float* o = j + 1 < n ? out + j * n : last;
      for (int i = 0; i < cols; i += kLanes) {
        store(o + i, w00 * load(f0 + i) + w01 * load(f0 + i + 1) + w10 * load(f1 + i) + w11 * load(f1 + i + 1));
      }
    }
    std::memcpy(out + (n - 1) * n, last, sizeof(float) * static_cast<std::size_t>(n));
  }

  const std::uint8_t* data_ = nullptr;  // the image whose pixels rows_ holds (none yet)
  int stride_ = 0, x0_ = 0, y0_ = 0, n_ = 0;
  alignas(16) float rows_[kMaxSrcRows][kMaxSrcRow];
};

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
      store(tmpl + k0 + i, load(c + i));
      store(gx + k0 + i, half * (load(c + i + 1) - load(c + i - 1)));
      store(gy + k0 + i, half * (load(c + i + ne) - load(c + i - ne)));
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
  if (!(max_mean_abs_error > 0.0f)) {
    throw std::invalid_argument("KltOptions.max_mean_abs_error must be > 0, got " + std::to_string(max_mean_abs_error));
  }
}

void sample_patch_bilinear(const ImageView& image, float x, float y, int n, float* out) {
  check_patch_size(n);
  SourceBlock block;
  block.sample(image, x, y, n, out);
}

namespace {

// One klt_track call's buffers: the template with its gradients, the warped window and the pixel
// blocks under both (stack, no allocation).
struct KltWorkspace {
  static constexpr int kMaxN = KltOptions::kMaxWindowPx;
  static constexpr int kMaxT = kMaxN + 2;
  // + kLanes: template_and_gradients reads and writes whole vectors past the last row's end.
  alignas(16) float tmpl_ext[kMaxT * kMaxT + kLanes];
  alignas(16) float tmpl[kMaxN * kMaxN + kLanes];
  alignas(16) float gx[kMaxN * kMaxN + kLanes];
  alignas(16) float gy[kMaxN * kMaxN + kLanes];
  alignas(16) float warped[kMaxN * kMaxN];
  SourceBlock template_block, warped_block;  // the pixels under the template and under the window
  GradientSums gs;
};

// Samples the template around p in I and its gradients into ws. False when the window is
// untextured: the smallest eigenvalue of the mean structure tensor is below min_eigen.
bool prepare_template(const ImageView& I, const Eigen::Vector2f& p, const KltOptions& options, KltWorkspace* ws) {
  const int n = options.window_px, half = n / 2, ne = n + 2, nn = n * n;
  const float inv_area = 1.0f / static_cast<float>(nn);
  ws->template_block.sample(I, p.x() - static_cast<float>(half + 1), p.y() - static_cast<float>(half + 1), ne, ws->tmpl_ext);
  std::fill(ws->tmpl_ext + ne * ne, ws->tmpl_ext + ne * ne + kLanes, 0.0f);  // read by the last row's spare lanes
  template_and_gradients(ws->tmpl_ext, n, ws->tmpl, ws->gx, ws->gy);
  ws->gs = gradient_sums(ws->gx, ws->gy, nn);
  const float a = ws->gs.gxx * inv_area, b = ws->gs.gxy * inv_area, c2 = ws->gs.gyy * inv_area;
  const float min_eig = 0.5f * ((a + c2) - std::sqrt((a - c2) * (a - c2) + 4.0f * b * b));
  return min_eig >= options.min_eigen && min_eig > 0.0f;
}

// Gauss-Newton iterations of one level from the carried displacement g: the flow nu on top of it.
// False when the window left J entirely or the flow ran farther than the window reaches (it has
// locked onto something else). *converged: the last update was below epsilon_px, so ws->warped
// (sampled before it) is the window at the result to within epsilon_px.
bool iterate_level(const ImageView& J, const Eigen::Vector2f& p, const Eigen::Vector2f& g, const KltOptions& options,
                   float epsilon_px, KltWorkspace* ws, Eigen::Vector2f* nu, bool* converged) {
  const int n = options.window_px, half = n / 2, nn = n * n;
  const float inv_area = 1.0f / static_cast<float>(nn);
  const GradientSums& gs = ws->gs;
  const float inv_det = 1.0f / (gs.gxx * gs.gyy - gs.gxy * gs.gxy);
  nu->setZero();
  *converged = false;
  for (int it = 0; it < options.max_iterations; ++it) {
    const float qx = p.x() + g.x() + nu->x(), qy = p.y() + g.y() + nu->y();
    if (!(qx > -static_cast<float>(half) && qy > -static_cast<float>(half) &&
          qx < static_cast<float>(J.width + half) && qy < static_cast<float>(J.height + half))) {
      return false;
    }
    ws->warped_block.sample(J, qx - static_cast<float>(half), qy - static_cast<float>(half), n, ws->warped);
    // Intensity offset between the windows (exposure, or the two cameras' gains) removed:
    // e = (T - mean T) - (J - mean J) = d - mean d with d = T - J, so
    // sum e g = sum d g - mean(d) sum g (d is small near convergence: no cancellation).
    const ErrorSums es = error_sums(ws->tmpl, ws->warped, ws->gx, ws->gy, nn);
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

}  // namespace

Status klt_track(const ImagePyramid& prev, const ImagePyramid& curr, int levels, const KltOptions& options,
                 const Eigen::Vector2f& p_prev, Eigen::Vector2f* p_curr) {
  KltWorkspace ws;
  const int half = options.window_px / 2;
  levels = std::min({levels, prev.levels(), curr.levels()});
  if (levels < 1 || !std::isfinite(p_curr->x()) || !std::isfinite(p_curr->y())) return Status::kNotConverged;

  const float top_scale = 1.0f / static_cast<float>(1 << (levels - 1));
  // Displacement (guess + flow) carried from level to level, in the current level's pixels.
  Eigen::Vector2f g = (*p_curr - p_prev) * top_scale;
  bool converged = false;
  for (int level = levels - 1; level >= 0; --level) {
    const Eigen::Vector2f p = p_prev * (1.0f / static_cast<float>(1 << level));
    // A coarse level that cannot be used (blurred flat, or mostly outside a small image) is
    // skipped: the finer levels still refine the carried displacement. Level 0 must succeed.
    if (!prepare_template(prev.level(level), p, options, &ws)) {
      if (level == 0) return Status::kNotConverged;
      g *= 2.0f;
      continue;
    }
    Eigen::Vector2f nu;
    if (!iterate_level(curr.level(level), p, g, options, level == 0 ? options.epsilon_px : options.coarse_epsilon_px, &ws,
                       &nu, &converged)) {
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
    ws.warped_block.sample(J0, result.x() - static_cast<float>(half), result.y() - static_cast<float>(half),
                           options.window_px, ws.warped);
  }
  const int nn = options.window_px * options.window_px;
  if (!(mean_abs_error(ws.tmpl, ws.warped, nn) <= options.max_mean_abs_error)) return Status::kNotConverged;
  *p_curr = result;
  return Status::kOk;
}

}  // namespace ums
