#include "core/frontend/klt_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

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

}  // namespace

void KltOptions::validate() const {
  if (window_px < 5 || window_px > kMaxWindowPx || window_px % 2 == 0) {
    throw std::invalid_argument("KltOptions.window_px must be odd in 5.." + std::to_string(kMaxWindowPx) +
                                ", got " + std::to_string(window_px));
  }
  if (max_iterations < 1) throw std::invalid_argument("KltOptions.max_iterations must be >= 1, got " + std::to_string(max_iterations));
  if (!(epsilon_px > 0.0f)) throw std::invalid_argument("KltOptions.epsilon_px must be > 0, got " + std::to_string(epsilon_px));
  if (!(min_eigen >= 0.0f)) throw std::invalid_argument("KltOptions.min_eigen must be >= 0, got " + std::to_string(min_eigen));
  if (!(max_mean_abs_error > 0.0f)) {
    throw std::invalid_argument("KltOptions.max_mean_abs_error must be > 0, got " + std::to_string(max_mean_abs_error));
  }
}

void sample_patch_bilinear(const ImageView& image, float x, float y, int n, float* out) {
  const float fx0 = std::floor(x), fy0 = std::floor(y);
  const int x0 = static_cast<int>(fx0), y0 = static_cast<int>(fy0);
  const float ax = x - fx0, ay = y - fy0;
  // One fraction for the whole patch: four weights, reused for every sample.
  const float w00 = (1.0f - ax) * (1.0f - ay), w01 = ax * (1.0f - ay), w10 = (1.0f - ax) * ay, w11 = ax * ay;
  constexpr int kMaxRow = KltOptions::kMaxWindowPx + 3;  // the largest patch sampled: window + 2, plus 1
  if (x0 >= 0 && y0 >= 0 && x0 + n < image.width && y0 + n < image.height && n + 1 <= kMaxRow) {
    // Each source row is converted to float once and serves two output rows. The products and
    // their order are those of the direct formula, so the samples are bit-identical to it.
    alignas(16) float rows[2][kMaxRow];
    auto convert = [&](int j, float* __restrict f) {
      const std::uint8_t* __restrict r = image.row(y0 + j) + x0;
      for (int i = 0; i <= n; ++i) f[i] = static_cast<float>(r[i]);
    };
    convert(0, rows[0]);
    for (int j = 0; j < n; ++j) {
      const float* __restrict f0 = rows[j & 1];
      float* __restrict f1 = rows[(j + 1) & 1];
      convert(j + 1, f1);
      float* __restrict o = out + j * n;
      for (int i = 0; i < n; ++i) o[i] = w00 * f0[i] + w01 * f0[i + 1] + w10 * f1[i] + w11 * f1[i + 1];
    }
    return;
  }
  const int wmax = image.width - 1, hmax = image.height - 1;
  for (int j = 0; j < n; ++j) {
    const std::uint8_t* r0 = image.row(std::clamp(y0 + j, 0, hmax));
    const std::uint8_t* r1 = image.row(std::clamp(y0 + j + 1, 0, hmax));
    float* o = out + j * n;
    for (int i = 0; i < n; ++i) {
      const int xa = std::clamp(x0 + i, 0, wmax), xb = std::clamp(x0 + i + 1, 0, wmax);
      o[i] = w00 * static_cast<float>(r0[xa]) + w01 * static_cast<float>(r0[xb]) + w10 * static_cast<float>(r1[xa]) +
             w11 * static_cast<float>(r1[xb]);
    }
  }
}

Status klt_track(const ImagePyramid& prev, const ImagePyramid& curr, int levels, const KltOptions& options,
                 const Eigen::Vector2f& p_prev, Eigen::Vector2f* p_curr) {
  constexpr int kMaxN = KltOptions::kMaxWindowPx;
  constexpr int kMaxT = kMaxN + 2;
  float tmpl_ext[kMaxT * kMaxT];
  alignas(16) float tmpl[kMaxN * kMaxN];
  alignas(16) float gx[kMaxN * kMaxN];
  alignas(16) float gy[kMaxN * kMaxN];
  alignas(16) float warped[kMaxN * kMaxN];

  const int n = options.window_px;
  const int half = n / 2;
  const int ne = n + 2;
  const int nn = n * n;
  const float inv_area = 1.0f / static_cast<float>(nn);
  levels = std::min({levels, prev.levels(), curr.levels()});
  if (levels < 1 || !std::isfinite(p_curr->x()) || !std::isfinite(p_curr->y())) return Status::kNotConverged;

  const float top_scale = 1.0f / static_cast<float>(1 << (levels - 1));
  // Displacement (guess + flow) carried from level to level, in the current level's pixels.
  Eigen::Vector2f g = (*p_curr - p_prev) * top_scale;
  for (int level = levels - 1; level >= 0; --level) {
    const float scale = 1.0f / static_cast<float>(1 << level);
    const ImageView& I = prev.level(level);
    const ImageView& J = curr.level(level);
    const Eigen::Vector2f p = p_prev * scale;

    sample_patch_bilinear(I, p.x() - static_cast<float>(half + 1), p.y() - static_cast<float>(half + 1), ne, tmpl_ext);
    for (int j = 0; j < n; ++j) {
      const float* c = tmpl_ext + (j + 1) * ne + 1;
      for (int i = 0; i < n; ++i) {
        const int k = j * n + i;
        tmpl[k] = c[i];
        gx[k] = 0.5f * (c[i + 1] - c[i - 1]);
        gy[k] = 0.5f * (c[i + ne] - c[i - ne]);
      }
    }
    const GradientSums gs = gradient_sums(gx, gy, nn);
    const float gxx = gs.gxx, gxy = gs.gxy, gyy = gs.gyy;
    // Smallest eigenvalue of the mean structure tensor: an untextured window cannot be tracked.
    const float a = gxx * inv_area, b = gxy * inv_area, c2 = gyy * inv_area;
    const float min_eig = 0.5f * ((a + c2) - std::sqrt((a - c2) * (a - c2) + 4.0f * b * b));
    // A coarse level that cannot be used (blurred flat, or mostly outside a small image) is
    // skipped: the finer levels still refine the carried displacement. Level 0 must succeed.
    const bool usable = min_eig >= options.min_eigen && min_eig > 0.0f;
    if (!usable) {
      if (level == 0) return Status::kNotConverged;
      g *= 2.0f;
      continue;
    }
    const float det = gxx * gyy - gxy * gxy;
    const float inv_det = 1.0f / det;

    Eigen::Vector2f nu(0.0f, 0.0f);
    bool left_image = false;
    for (int it = 0; it < options.max_iterations; ++it) {
      const float qx = p.x() + g.x() + nu.x(), qy = p.y() + g.y() + nu.y();
      if (!(qx > -static_cast<float>(half) && qy > -static_cast<float>(half) &&
            qx < static_cast<float>(J.width + half) && qy < static_cast<float>(J.height + half))) {
        left_image = true;  // the window left the image entirely
        break;
      }
      sample_patch_bilinear(J, qx - static_cast<float>(half), qy - static_cast<float>(half), n, warped);
      // Intensity offset between the windows (exposure, or the two cameras' gains) removed:
      // e = (T - mean T) - (J - mean J) = d - mean d with d = T - J, so
      // sum e g = sum d g - mean(d) sum g (d is small near convergence: no cancellation).
      const ErrorSums es = error_sums(tmpl, warped, gx, gy, nn);
      const float mean_d = es.d * inv_area;
      const float bx = es.dgx - mean_d * gs.gx;
      const float by = es.dgy - mean_d * gs.gy;
      const float ex = inv_det * (gyy * bx - gxy * by);
      const float ey = inv_det * (gxx * by - gxy * bx);
      nu.x() += ex;
      nu.y() += ey;
      if (ex * ex + ey * ey < options.epsilon_px * options.epsilon_px) break;
    }
    // A level whose flow runs farther than the window reaches has locked onto something else.
    const bool ran_away = !(nu.squaredNorm() <= static_cast<float>(half * half));
    if (left_image || ran_away) {
      if (level == 0) return Status::kNotConverged;
      nu.setZero();
    }
    if (level > 0) {
      g = 2.0f * (g + nu);
    } else {
      g += nu;
    }
  }
  const Eigen::Vector2f result = p_prev + g;
  const ImageView& J0 = curr.level(0);
  if (!(result.x() >= 0.0f && result.y() >= 0.0f && result.x() <= static_cast<float>(J0.width - 1) &&
        result.y() <= static_cast<float>(J0.height - 1))) {
    return Status::kNotConverged;
  }
  // Photometric check at level 0 (the template was sampled at level 0 in the last pass).
  sample_patch_bilinear(J0, result.x() - static_cast<float>(half), result.y() - static_cast<float>(half), n, warped);
  if (!(mean_abs_error(tmpl, warped, nn) <= options.max_mean_abs_error)) return Status::kNotConverged;
  *p_curr = result;
  return Status::kOk;
}

}  // namespace ums
