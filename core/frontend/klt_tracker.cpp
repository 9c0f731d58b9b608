#include "core/frontend/klt_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace ums {

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
  // The window sums are Eigen array reductions (vectorised, several partial sums).
  using ArrMap = Eigen::Map<const Eigen::ArrayXf, Eigen::Aligned16>;
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
    const ArrMap GX(gx, nn), GY(gy, nn);
    const float gxx = GX.square().sum(), gxy = (GX * GY).sum(), gyy = GY.square().sum();
    const float sum_gx = GX.sum(), sum_gy = GY.sum();
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
      const ArrMap T(tmpl, nn), W(warped, nn);
      const float sum_d = (T - W).sum();
      float bx = ((T - W) * GX).sum();
      float by = ((T - W) * GY).sum();
      const float mean_d = sum_d * inv_area;
      bx -= mean_d * sum_gx;
      by -= mean_d * sum_gy;
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
  const ArrMap T(tmpl, nn), W(warped, nn);
  const float mean_d = (T - W).sum() * inv_area;
  const float sum_abs = (T - W - mean_d).abs().sum();
  if (!(sum_abs * inv_area <= options.max_mean_abs_error)) return Status::kNotConverged;
  *p_curr = result;
  return Status::kOk;
}

}  // namespace ums
