#include "core/frontend/corner_detector.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <catch2/catch.hpp>

#include "profiling/alloc_counter.hpp"
#include "tests/core/frontend/synthetic_images.hpp"

namespace {

// Distance from p to the nearest checkerboard corner origin + k * square.
double corner_error(const Eigen::Vector2f& p, const Eigen::Vector2d& origin, double square) {
  const double kx = std::round((static_cast<double>(p.x()) - origin.x()) / square);
  const double ky = std::round((static_cast<double>(p.y()) - origin.y()) / square);
  return (Eigen::Vector2d(origin.x() + kx * square, origin.y() + ky * square) - p.cast<double>()).norm();
}

}  // namespace

TEST_CASE("Shi-Tomasi + sub-pixel refinement finds checkerboard corners to better than 0.1 px") {
  const Eigen::Vector2d origin(20.37, 15.71);
  const double square = 23.0;
  const ums::test::GreyImage img = ums::test::render_checkerboard(300, 220, square, origin);
  ums::CornerDetector det(300, 220);
  ums::DetectorOptions opt;
  opt.min_distance_px = 10.0f;
  Eigen::Vector2f pts[200];
  det.clear_mask();
  const int n = det.detect(img.view(), 200, opt, pts);
  double sq = 0.0, worst = 0.0, sq_int = 0.0;
  for (int i = 0; i < n; ++i) {
    const double e = corner_error(pts[i], origin, square);
    sq += e * e;
    worst = std::max(worst, e);
    // What the integer NMS position alone would give.
    const Eigen::Vector2f rounded(std::round(pts[i].x()), std::round(pts[i].y()));
    const double ei = corner_error(rounded, origin, square);
    sq_int += ei * ei;
  }
  const double rms = std::sqrt(sq / n), rms_int = std::sqrt(sq_int / n);
  INFO("corners " << n << " rms " << rms << " px (integer positions: " << rms_int << " px), worst " << worst);
  // (300-20)/23 x (220-16)/23 = 12 x 8 interior corners, minus the border band.
  CHECK(n >= 70);
  // Measured 0.071 px: a position-dependent bias of bilinearly sampled gradients on this perfectly
  // sharp (box-filtered) edge; the integer grid alone is 0.47 px.
  CHECK(rms < 0.1);
  CHECK(worst < 0.12);
  CHECK(rms_int > 0.3);  // the refinement, not the grid, did the work
}

TEST_CASE("detection keeps min_distance between features, honours the mask, and allocates nothing") {
  const ums::test::BlobTexture tex(320, 240, 900, 99u);
  const ums::test::GreyImage img = tex.render(320, 240);
  ums::CornerDetector det(320, 240);
  ums::DetectorOptions opt;
  opt.min_distance_px = 20.0f;
  Eigen::Vector2f pts[300];
  det.clear_mask();
  const Eigen::Vector2f blocked(160.0f, 120.0f);
  det.block_disk(blocked, 50.0f);
  ums::AllocScope scope;
  const int n = det.detect(img.view(), 300, opt, pts);
  if (ums::alloc_counter_available()) CHECK(scope.allocations() == 0);
  REQUIRE(n > 30);
  double min_d = 1e9;
  for (int i = 0; i < n; ++i) {
    CHECK((pts[i] - blocked).norm() > 49.0f);
    // Refinement may move a corner by up to its window half size from the NMS pixel.
    CHECK(pts[i].x() >= opt.border_px - opt.subpix_half_window);
    CHECK(pts[i].y() <= 239 - opt.border_px + opt.subpix_half_window);
    for (int j = 0; j < i; ++j) min_d = std::min(min_d, static_cast<double>((pts[i] - pts[j]).norm()));
  }
  INFO("features " << n << " min pairwise distance " << min_d);
  CHECK(min_d >= 19.0);  // mask rounding only
}

TEST_CASE("a flat image with sensor-like noise yields no corners (absolute response floor)") {
  ums::test::GreyImage img(200, 150);
  std::uint32_t s = 7;
  for (auto& p : img.pixels) {
    s ^= s << 13;
    s ^= s >> 17;
    s ^= s << 5;
    p = static_cast<std::uint8_t>(120 + static_cast<int>(s % 5) - 2);  // +-2 grey levels
  }
  ums::CornerDetector det(200, 150);
  Eigen::Vector2f pts[50];
  det.clear_mask();
  CHECK(det.detect(img.view(), 50, ums::DetectorOptions{}, pts) == 0);
}

namespace {

// The direct form of the response at (x, y): Sobel products of the 3x3 neighbourhood summed
// row by row, one pixel at a time (no vector lanes).
float direct_response(const ums::ImageView& v, int x, int y, float* trace = nullptr) {
  float sa = 0.0f, sb = 0.0f, sc = 0.0f;
  for (int j = -1; j <= 1; ++j) {
    float ra = 0.0f, rb = 0.0f, rc = 0.0f;
    for (int i = -1; i <= 1; ++i) {
      const int cx = x + i, cy = y + j;
      const std::uint8_t* r0 = v.row(cy - 1);
      const std::uint8_t* r1 = v.row(cy);
      const std::uint8_t* r2 = v.row(cy + 1);
      const float dx = static_cast<float>((r0[cx + 1] - r0[cx - 1]) + 2 * (r1[cx + 1] - r1[cx - 1]) + (r2[cx + 1] - r2[cx - 1]));
      const float dy = static_cast<float>((r2[cx - 1] - r0[cx - 1]) + 2 * (r2[cx] - r0[cx]) + (r2[cx + 1] - r0[cx + 1]));
      ra += dx * dx;
      rb += dx * dy;
      rc += dy * dy;
    }
    sa += ra;
    sb += rb;
    sc += rc;
  }
  const float k = 1.0f / (8.0f * 8.0f * 9.0f);
  sa *= k;
  sb *= k;
  sc *= k;
  if (trace != nullptr) *trace = sa + sc;
  return 0.5f * ((sa + sc) - std::sqrt((sa - sc) * (sa - sc) + 4.0f * sb * sb));
}

// Random pixels with a band of 0/255 single-pixel checkers: Sobel magnitudes up to 4 * 255, where
// nine squared products come closest to 2^24 (the bound that keeps every float sum exact).
ums::test::GreyImage random_with_checker_band(int w, int h) {
  ums::test::GreyImage img(w, h);
  std::uint32_t s = 2463534242u;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      s ^= s << 13;
      s ^= s >> 17;
      s ^= s << 5;
      img.at(x, y) = (y >= 20 && y < 30) ? static_cast<std::uint8_t>(((x + y) & 1) * 255) : static_cast<std::uint8_t>(s >> 24);
    }
  }
  return img;
}

}  // namespace

TEST_CASE("the separable Shi-Tomasi response equals the direct 3x3 sum bit for bit, extreme gradients included") {
  const int w = 97, h = 61;
  const ums::test::GreyImage img = random_with_checker_band(w, h);
  ums::CornerDetector det(w, h);
  det.clear_mask();
  Eigen::Vector2f pts[4];
  ums::DetectorOptions opt;
  (void)det.detect(img.view(), 4, opt, pts);
  const ums::ImageView v = img.view();
  int mismatches = 0, nonzero_border = 0, missing = 0;
  float largest = 0.0f;
  const int b = opt.border_px;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (y < 2 || y >= h - 2 || x < 2 || x >= w - 2) {
        nonzero_border += det.response(x, y) != 0.0f ? 1 : 0;
        continue;
      }
      if (!std::isfinite(det.response(x, y))) {
        // With nothing masked, every pixel within one of the border box must have been computed.
        missing += (x >= b - 1 && x <= w - b && y >= b - 1 && y <= h - b) ? 1 : 0;
        continue;
      }
      float trace = 0.0f;
      mismatches += det.response(x, y) != direct_response(v, x, y, &trace) ? 1 : 0;
      largest = std::max(largest, trace);
    }
  }
  INFO("largest Ixx + Iyy " << largest << " (grey/px)^2");
  CHECK(largest > 3000.0f);  // the checker band did reach near-maximal gradients
  CHECK(mismatches == 0);
  CHECK(nonzero_border == 0);
  CHECK(missing == 0);
}

TEST_CASE("between mask disks, the runs detection computes give the direct 3x3 response bit for bit") {
  // Disks of growing radius along the rows leave free runs of many lengths; the response is
  // computed over their column groups (8 pixels, and 1-2 pixels of padding): the kernels' widest
  // steps, their overlapping last steps and the narrower steps.
  const int w = 131, h = 61;
  const ums::test::GreyImage img = random_with_checker_band(w, h);
  ums::CornerDetector det(w, h);
  det.clear_mask();
  for (int y = 4, r = 2; y < h; y += 7, ++r)
    for (int x = y % 11; x < w; x += 2 * r + 1 + (x % 5)) det.block_disk(Eigen::Vector2f(x, y), static_cast<float>(r));
  Eigen::Vector2f pts[4];
  (void)det.detect(img.view(), 4, ums::DetectorOptions{}, pts);
  int computed = 0, mismatches = 0;
  for (int y = 2; y < h - 2; ++y) {
    for (int x = 2; x < w - 2; ++x) {
      const float r = det.response(x, y);
      if (!std::isfinite(r)) continue;
      ++computed;
      mismatches += r != direct_response(img.view(), x, y) ? 1 : 0;
    }
  }
  INFO(computed << " pixels computed of " << (w - 4) * (h - 4));
  CHECK(computed > 1000);
  CHECK(computed < (w - 4) * (h - 4));  // the mask did cut the rows into runs
  CHECK(mismatches == 0);
}

TEST_CASE("under a mask the response is computed around free pixels only, equal to the unmasked one") {
  const int w = 320, h = 240;
  const ums::test::BlobTexture tex(w, h, 900, 5u);
  const ums::test::GreyImage img = tex.render(w, h);
  ums::DetectorOptions opt;
  Eigen::Vector2f pts[8];
  ums::CornerDetector full(w, h), masked(w, h);
  full.clear_mask();
  (void)full.detect(img.view(), 1, opt, pts);
  // Disks over most of the image, as the tracked features leave it in flight.
  masked.clear_mask();
  for (int y = 0; y < h; y += 30)
    for (int x = (y / 30) % 2 * 15; x < w; x += 30) masked.block_disk(Eigen::Vector2f(x, y), 16.0f);
  std::vector<std::uint8_t> was_free(static_cast<std::size_t>(w * h));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) was_free[static_cast<std::size_t>(y * w + x)] = masked.is_free(Eigen::Vector2f(x, y)) ? 1 : 0;
  (void)masked.detect(img.view(), 1, opt, pts);
  const int b = opt.border_px;
  int computed = 0, interior = 0, wrong = 0, missing_near_free = 0;
  for (int y = 2; y < h - 2; ++y) {
    for (int x = 2; x < w - 2; ++x) {
      ++interior;
      bool near_free = false;  // a free pixel inside the border within one pixel
      for (int j = -1; j <= 1; ++j)
        for (int i = -1; i <= 1; ++i) {
          const int fx = x + i, fy = y + j;
          near_free |= fx >= b && fx < w - b && fy >= b && fy < h - b && was_free[static_cast<std::size_t>(fy * w + fx)] != 0;
        }
      const float r = masked.response(x, y);
      if (!std::isfinite(r)) {
        missing_near_free += near_free ? 1 : 0;
        continue;
      }
      ++computed;
      wrong += r != full.response(x, y) ? 1 : 0;
    }
  }
  INFO("computed " << computed << " of " << interior << " interior pixels");
  CHECK(missing_near_free == 0);
  CHECK(wrong == 0);
  CHECK(computed < interior / 2);  // the point of the mask: most of the image is skipped
}

TEST_CASE("the quality threshold is relative to the strongest free response, not to a masked corner") {
  // A high-contrast checkerboard on the left (masked: tracked already) and faint corners (a
  // 12-grey-level checkerboard) on the right. 0.1 of the strong corners' response is above the
  // faint ones', 0.1 of the faint ones' is not.
  const int w = 240, h = 120;
  ums::test::GreyImage img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool odd = ((x / 20) + (y / 20)) % 2 != 0;
      img.at(x, y) = static_cast<std::uint8_t>(x < 120 ? (odd ? 250 : 5) : (odd ? 134 : 122));
    }
  ums::DetectorOptions opt;
  opt.quality_level = 0.1f;
  opt.min_distance_px = 10.0f;
  Eigen::Vector2f pts[40];
  ums::CornerDetector det(w, h);
  det.clear_mask();
  const int n_all = det.detect(img.view(), 40, opt, pts);
  int right_all = 0;
  for (int i = 0; i < n_all; ++i) right_all += pts[i].x() > 125.0f ? 1 : 0;
  det.clear_mask();
  for (int y = 0; y < h; y += 4) det.block_disk(Eigen::Vector2f(60.0f, static_cast<float>(y)), 64.0f);
  const int n = det.detect(img.view(), 40, opt, pts);
  int right = 0;
  for (int i = 0; i < n; ++i) right += pts[i].x() > 125.0f ? 1 : 0;
  INFO("unmasked: " << n_all << " corners, " << right_all << " faint; masked: " << n << " corners, " << right << " faint");
  CHECK(right_all == 0);  // the strong corners set the bar while they are free
  CHECK(right >= 16);     // 5 columns x 5 rows of faint corners inside the border: 25 found
  CHECK(right == n);
}

TEST_CASE("corners of equal response are placed in scan order, strongest first") {
  // Two identical bright squares, 50 px apart: every corner of the right one ties with its twin
  // on the left. Detection places corners strongest first; of equal ones, the first in scan
  // order (lower y, then lower x) wins, so each accepted left corner precedes its right twin.
  const int w = 140, h = 60;
  ums::test::GreyImage img(w, h, 20);
  for (int y = 24; y < 32; ++y)
    for (int x = 0; x < 8; ++x) {
      img.at(30 + x, y) = 200;
      img.at(80 + x, y) = 200;
    }
  ums::CornerDetector det(w, h);
  det.clear_mask();
  ums::DetectorOptions opt;
  opt.min_distance_px = 3.0f;
  Eigen::Vector2f pts[16];
  const int n = det.detect(img.view(), 16, opt, pts);
  REQUIRE(n >= 8);  // four corners per square
  // The strongest response and the first pixel in scan order that reaches it.
  float best = 0.0f;
  Eigen::Vector2f first(-1.0f, -1.0f);
  for (int y = opt.border_px; y < h - opt.border_px; ++y)
    for (int x = opt.border_px; x < w - opt.border_px; ++x)
      if (det.response(x, y) > best) {
        best = det.response(x, y);
        first = Eigen::Vector2f(static_cast<float>(x), static_cast<float>(y));
      }
  REQUIRE(first.x() < 60.0f);  // the tie: the left square's corner comes first in scan order
  CHECK((pts[0] - first).norm() < 1.5f);  // refined by at most a pixel or so
  // Twins come in pairs: left corner k, then (after any other left corners of the same score)
  // its right twin 50 px to the right; no right corner precedes its left twin.
  for (int i = 0; i < n; ++i) {
    if (pts[i].x() < 60.0f) continue;
    bool twin_before = false;
    for (int j = 0; j < i; ++j) twin_before |= (pts[j] + Eigen::Vector2f(50.0f, 0.0f) - pts[i]).norm() < 0.01f;
    CHECK(twin_before);
  }
}

namespace {

// detect()'s selection written plainly, for the detector det has just run (its responses) on
// img with the mask that `mask` holds: every free pixel inside the border at or above the
// threshold that is a 3x3 maximum (ties to the first in scan order), offered in scan order to a
// min-heap by score holding the strongest kMaxCornerCandidates; then strongest first (equal
// scores in scan order), each refined and placed when still free, blocking its disk in `mask`.
std::vector<Eigen::Vector2f> reference_selection(const ums::CornerDetector& det, ums::CornerDetector& mask,
                                                 const ums::ImageView& img, const ums::DetectorOptions& opt,
                                                 int max_new, int* offered) {
  struct C {
    float score;
    int x, y;
  };
  const int w = img.width, h = img.height, b = std::max(opt.border_px, 3);
  auto free_at = [&](int x, int y) { return mask.is_free(Eigen::Vector2f(static_cast<float>(x), static_cast<float>(y))); };
  float max_r = 0.0f;
  for (int y = b; y < h - b; ++y)
    for (int x = b; x < w - b; ++x)
      if (free_at(x, y)) max_r = std::max(max_r, det.response(x, y));
  const float thresh = std::max(opt.min_response, opt.quality_level * max_r);
  std::vector<C> heap;
  const auto greater = [](const C& l, const C& r) { return l.score > r.score; };
  for (int y = b; y < h - b; ++y) {
    for (int x = b; x < w - b; ++x) {
      const float v = det.response(x, y);
      if (!free_at(x, y) || !(v >= thresh)) continue;
      bool is_max = true;
      for (int j = -1; j <= 1; ++j)
        for (int i = -1; i <= 1; ++i) {
          if (i == 0 && j == 0) continue;
          const float u = det.response(x + i, y + j);
          const bool before = j < 0 || (j == 0 && i < 0);  // earlier in scan order: strictly greater
          is_max = is_max && (before ? v > u : v >= u);
        }
      if (!is_max) continue;
      ++*offered;
      if (heap.size() < ums::capacity::kMaxCornerCandidates) {
        heap.push_back(C{v, x, y});
        std::push_heap(heap.begin(), heap.end(), greater);
      } else if (v > heap.front().score) {
        std::pop_heap(heap.begin(), heap.end(), greater);
        heap.back() = C{v, x, y};
        std::push_heap(heap.begin(), heap.end(), greater);
      }
    }
  }
  std::sort(heap.begin(), heap.end(), [](const C& l, const C& r) {
    if (l.score != r.score) return l.score > r.score;
    return l.y != r.y ? l.y < r.y : l.x < r.x;
  });
  std::vector<Eigen::Vector2f> out;
  for (const C& c : heap) {
    if (static_cast<int>(out.size()) >= max_new) break;
    Eigen::Vector2f p(static_cast<float>(c.x), static_cast<float>(c.y));
    if (!mask.is_free(p)) continue;
    ums::CornerDetector::refine_subpixel(img, opt, &p);
    if (!mask.is_free(p)) continue;
    out.push_back(p);
    mask.block_disk(p, opt.min_distance_px);
  }
  return out;
}

}  // namespace

TEST_CASE("detection selects as a bounded heap of the strongest candidates would, beyond its capacity and with ties") {
  // More 3x3 maxima than kMaxCornerCandidates: blobs, and on the left a faint 4-px checkerboard
  // whose corners all have one response, the weakest in view: the store evicts among equal
  // scores (a heap built otherwise than by pushing each candidate in turn fails here). Then a
  // mask of disks, as tracked features leave it.
  const int w = 752, h = 480;
  const ums::test::BlobTexture tex(w, h, 300, 11u);
  ums::test::GreyImage img = tex.render(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w / 2; ++x) img.at(x, y) = static_cast<std::uint8_t>(((x / 4 + y / 4) % 2 != 0) ? 130 : 100);
  ums::DetectorOptions opt;
  opt.min_distance_px = 3.0f;
  constexpr int kMaxNew = 300;
  for (const bool masked : {false, true}) {
    ums::CornerDetector det(w, h), ref_mask(w, h);
    det.clear_mask();
    ref_mask.clear_mask();
    if (masked) {
      for (int y = 0; y < h; y += 40)
        for (int x = (y / 40) % 2 * 20; x < w; x += 40) {
          det.block_disk(Eigen::Vector2f(x, y), 12.0f);
          ref_mask.block_disk(Eigen::Vector2f(x, y), 12.0f);
        }
    }
    Eigen::Vector2f pts[kMaxNew];
    const int n = det.detect(img.view(), kMaxNew, opt, pts);
    int offered = 0;
    const std::vector<Eigen::Vector2f> ref = reference_selection(det, ref_mask, img.view(), opt, kMaxNew, &offered);
    INFO((masked ? "masked" : "unmasked") << ": " << n << " corners, reference " << ref.size() << ", " << offered
                                          << " candidates");
    CHECK(offered > static_cast<int>(ums::capacity::kMaxCornerCandidates));  // the store evicted
    REQUIRE(n == static_cast<int>(ref.size()));
    CHECK(n > 100);
    int differ = 0;
    for (int i = 0; i < n; ++i) differ += (pts[i] - ref[static_cast<std::size_t>(i)]).norm() > 0.0f ? 1 : 0;
    CHECK(differ == 0);
  }
}
