#include "core/frontend/corner_detector.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "core/frontend/klt_tracker.hpp"

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
  rows_.assign(static_cast<std::size_t>(9 * width), 0.0f);
  mask_.assign(n, 0);
  heap_.reserve(capacity::kMaxCornerCandidates);
}

void CornerDetector::clear_mask() { std::memset(mask_.data(), 0, mask_.size()); }

void CornerDetector::block_disk(const Eigen::Vector2f& c, float r) {
  if (!std::isfinite(c.x()) || !std::isfinite(c.y())) return;
  const int y_lo = std::max(0, static_cast<int>(std::ceil(c.y() - r)));
  const int y_hi = std::min(height_ - 1, static_cast<int>(std::floor(c.y() + r)));
  for (int y = y_lo; y <= y_hi; ++y) {
    const float dy = static_cast<float>(y) - c.y();
    const float dx = std::sqrt(std::max(0.0f, r * r - dy * dy));
    const int x_lo = std::max(0, static_cast<int>(std::ceil(c.x() - dx)));
    const int x_hi = std::min(width_ - 1, static_cast<int>(std::floor(c.x() + dx)));
    if (x_hi >= x_lo) std::memset(mask_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(width_) + x_lo, 1, static_cast<std::size_t>(x_hi - x_lo + 1));
  }
}

bool CornerDetector::is_free(const Eigen::Vector2f& p) const {
  const int x = static_cast<int>(std::lround(p.x())), y = static_cast<int>(std::lround(p.y()));
  if (x < 0 || y < 0 || x >= width_ || y >= height_) return false;
  return mask_[static_cast<std::size_t>(y) * static_cast<std::size_t>(width_) + static_cast<std::size_t>(x)] == 0;
}

// Rolling computation: the Sobel products of row y go into ring slot y % 3; the response of row
// y - 1 is the 3x3 box sum over slots (y-2, y-1, y). Responses of the outer ring are zero.
void CornerDetector::compute_response(const ImageView& img) {
  const int w = width_, h = height_;
  const float kNorm = 1.0f / (8.0f * 8.0f * 9.0f);  // Sobel gain 8 per gradient, 9-pixel block mean
  std::memset(response_.data(), 0, response_.size() * sizeof(float));
  auto products = [&](int y, float* xx, float* xy, float* yy) {
    const std::uint8_t* r0 = img.row(y - 1);
    const std::uint8_t* r1 = img.row(y);
    const std::uint8_t* r2 = img.row(y + 1);
    xx[0] = xy[0] = yy[0] = 0.0f;
    xx[w - 1] = xy[w - 1] = yy[w - 1] = 0.0f;
    for (int x = 1; x < w - 1; ++x) {
      const int dx = (r0[x + 1] - r0[x - 1]) + 2 * (r1[x + 1] - r1[x - 1]) + (r2[x + 1] - r2[x - 1]);
      const int dy = (r2[x - 1] - r0[x - 1]) + 2 * (r2[x] - r0[x]) + (r2[x + 1] - r0[x + 1]);
      const float fdx = static_cast<float>(dx), fdy = static_cast<float>(dy);
      xx[x] = fdx * fdx;
      xy[x] = fdx * fdy;
      yy[x] = fdy * fdy;
    }
  };
  float* base = rows_.data();
  auto slot = [&](int y, int which) { return base + static_cast<std::size_t>(((y % 3) * 3 + which) * w); };
  for (int y = 1; y < h - 1; ++y) {
    products(y, slot(y, 0), slot(y, 1), slot(y, 2));
    if (y < 3) continue;
    const int yc = y - 1;  // rows yc-1, yc, yc+1 = y-2, y-1, y are all in the ring
    const float* a[3] = {slot(y - 2, 0), slot(y - 1, 0), slot(y, 0)};
    const float* b[3] = {slot(y - 2, 1), slot(y - 1, 1), slot(y, 1)};
    const float* c[3] = {slot(y - 2, 2), slot(y - 1, 2), slot(y, 2)};
    float* out = response_.data() + static_cast<std::size_t>(yc) * static_cast<std::size_t>(w);
    for (int x = 2; x < w - 2; ++x) {
      float sa = 0.0f, sb = 0.0f, sc = 0.0f;
      for (int k = 0; k < 3; ++k) {
        sa += a[k][x - 1] + a[k][x] + a[k][x + 1];
        sb += b[k][x - 1] + b[k][x] + b[k][x + 1];
        sc += c[k][x - 1] + c[k][x] + c[k][x + 1];
      }
      sa *= kNorm;
      sb *= kNorm;
      sc *= kNorm;
      out[x] = 0.5f * ((sa + sc) - std::sqrt((sa - sc) * (sa - sc) + 4.0f * sb * sb));
    }
  }
}

int CornerDetector::detect(const ImageView& image, int max_new, const DetectorOptions& options, Eigen::Vector2f* out_px) {
  if (max_new <= 0 || !image.valid() || image.width != width_ || image.height != height_) return 0;
  compute_response(image);
  const int w = width_, h = height_;
  const int b = std::max(options.border_px, 3);
  float max_r = 0.0f;
  for (int y = b; y < h - b; ++y) {
    const float* r = response_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(w);
    for (int x = b; x < w - b; ++x) max_r = std::max(max_r, r[x]);
  }
  const float thresh = std::max(options.min_response, options.quality_level * max_r);
  auto greater = [](const Candidate& l, const Candidate& r) { return l.score > r.score; };  // min-heap
  heap_.clear();
  const std::size_t cap = capacity::kMaxCornerCandidates;
  for (int y = b; y < h - b; ++y) {
    const float* rm = response_.data() + static_cast<std::size_t>(y - 1) * static_cast<std::size_t>(w);
    const float* r0 = rm + w;
    const float* rp = r0 + w;
    const std::uint8_t* m = mask_.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(w);
    for (int x = b; x < w - b; ++x) {
      const float v = r0[x];
      if (v < thresh || m[x] != 0) continue;
      // 3x3 maximum; ties go to the first pixel in scan order.
      if (!(v > rm[x - 1] && v > rm[x] && v > rm[x + 1] && v > r0[x - 1] && v >= r0[x + 1] && v >= rp[x - 1] &&
            v >= rp[x] && v >= rp[x + 1])) {
        continue;
      }
      if (heap_.size() < cap) {
        heap_.push_back(Candidate{v, x, y});  // within reserved capacity: no allocation
        std::push_heap(heap_.begin(), heap_.end(), greater);
      } else if (v > heap_.front().score) {
        std::pop_heap(heap_.begin(), heap_.end(), greater);
        heap_.back() = Candidate{v, x, y};
        std::push_heap(heap_.begin(), heap_.end(), greater);
      }
    }
  }
  std::sort_heap(heap_.begin(), heap_.end(), greater);  // descending score
  int count = 0;
  for (const Candidate& c : heap_) {
    if (count >= max_new) break;
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
