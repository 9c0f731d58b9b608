#include "core/frontend/klt_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include <catch2/catch.hpp>

#include "core/frontend/corner_detector.hpp"
#include "core/frontend/frontend.hpp"
#include "core/frontend/image_pyramid.hpp"
#include "core/frontend/klt_template_cache.hpp"
#include "tests/core/frontend/synthetic_images.hpp"

namespace {

struct KltResult {
  int attempted = 0;
  int tracked = 0;
  int accurate = 0;  // tracked and within 0.2 px of the truth
  double rms_px = 0.0;
  double max_px = 0.0;
};

// A blob texture and its rotated and shifted rendering (about the image centre), their 4-level
// pyramids and up to 150 corners of the first.
struct Scene {
  // 640 x 480: the 4th level (80 x 60) must still hold a 21 px window.
  static constexpr int kW = 640, kH = 480;
  Scene(double angle_rad, const Eigen::Vector2d& shift) : pa(kW, kH, 4), pb(kW, kH, 4) {
    const ums::test::BlobTexture tex(kW, kH, 1800, 12345u);
    const ums::test::GreyImage a = tex.render(kW, kH);
    const ums::test::GreyImage b = tex.render(kW, kH, angle_rad, shift, pivot);
    REQUIRE(pa.build(a.view()) == ums::Status::kOk);
    REQUIRE(pb.build(b.view()) == ums::Status::kOk);
    ums::CornerDetector det(kW, kH);
    ums::DetectorOptions dopt;
    dopt.min_distance_px = 20.0f;
    det.clear_mask();
    n = det.detect(a.view(), 150, dopt, pts);
  }
  const Eigen::Vector2d pivot{kW / 2.0, kH / 2.0};
  ums::ImagePyramid pa, pb;
  Eigen::Vector2f pts[150];
  int n = 0;
};

// Detects corners in the first rendering, tracks them into the transformed one (kept only when
// tracking back returns within 0.5 px, as in the front end) and compares with the exact
// transform.
KltResult track_transformed(double angle_rad, Eigen::Vector2d shift, int levels, bool use_truth_guess = false,
                            int window_px = ums::KltOptions{}.window_px,
                            int sparse_from_level = ums::KltOptions{}.sparse_from_level,
                            int confirm_sparse_from_level = ums::FrontendOptions{}.confirm_sparse_from_level) {
  const Scene sc(angle_rad, shift);
  const int w = Scene::kW, h = Scene::kH, n = sc.n;
  const Eigen::Vector2d pivot = sc.pivot;
  const Eigen::Vector2f* pts = sc.pts;
  const ums::ImagePyramid &pa = sc.pa, &pb = sc.pb;
  REQUIRE(n > 50);
  ums::KltOptions opt;
  opt.window_px = window_px;
  opt.sparse_from_level = sparse_from_level;
  ums::KltOptions confirm = opt;
  confirm.sparse_from_level = confirm_sparse_from_level;
  KltResult r;
  double sq = 0.0;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d truth = ums::test::BlobTexture::transform(pts[i].cast<double>(), angle_rad, shift, pivot);
    if (truth.x() < 12 || truth.y() < 12 || truth.x() > w - 13 || truth.y() > h - 13) continue;
    ++r.attempted;
    Eigen::Vector2f p = use_truth_guess ? truth.cast<float>() : pts[i];
    if (ums::klt_track(pa, pb, levels, opt, pts[i], &p) != ums::Status::kOk) continue;
    // Forward-backward check as the front end applies it (0.5 px).
    Eigen::Vector2f back = pts[i];
    if (ums::klt_track(pb, pa, levels, confirm, p, &back) != ums::Status::kOk || (back - pts[i]).norm() > 0.5f) continue;
    ++r.tracked;
    const double e = (p.cast<double>() - truth).norm();
    sq += e * e;
    r.accurate += e < 0.2 ? 1 : 0;
    r.max_px = std::max(r.max_px, e);
  }
  r.rms_px = r.tracked > 0 ? std::sqrt(sq / r.tracked) : 1e9;
  return r;
}

// Forward tracks on 4 levels (a 1 degree rotation and a 7.3 px shift), displaced by `error` px
// (a wrong match), then the front end's confirmation: tracked back on `levels_back` levels from
// the forward track's origin, kept within 0.5 px. Returns how many of the forward tracks it kept.
int confirmed_tracks(int levels_back, Eigen::Vector2f error, int* forward,
                     int confirm_sparse_from_level = ums::FrontendOptions{}.confirm_sparse_from_level) {
  const Scene sc(1.0 * M_PI / 180.0, Eigen::Vector2d(7.3, -4.6));
  const int n = sc.n;
  const Eigen::Vector2f* pts = sc.pts;
  const ums::ImagePyramid &pa = sc.pa, &pb = sc.pb;
  const ums::KltOptions opt;
  ums::KltOptions confirm;
  confirm.sparse_from_level = confirm_sparse_from_level;
  int kept = 0;
  *forward = 0;
  for (int i = 0; i < n; ++i) {
    Eigen::Vector2f p = pts[i];
    if (ums::klt_track(pa, pb, 4, opt, pts[i], &p) != ums::Status::kOk) continue;
    ++*forward;
    Eigen::Vector2f back = pts[i];
    if (ums::klt_track(pb, pa, levels_back, confirm, p + error, &back) == ums::Status::kOk && (back - pts[i]).norm() <= 0.5f) ++kept;
  }
  return kept;
}

}  // namespace

TEST_CASE("the backward check on level 0 alone keeps the good tracks and drops displaced ones, as 4 levels do") {
  int forward = 0;
  const int good1 = confirmed_tracks(1, Eigen::Vector2f::Zero(), &forward);
  const int good4 = confirmed_tracks(4, Eigen::Vector2f::Zero(), &forward);
  const int near1 = confirmed_tracks(1, Eigen::Vector2f(0.9f, -0.6f), &forward);
  const int near4 = confirmed_tracks(4, Eigen::Vector2f(0.9f, -0.6f), &forward);
  const int far1 = confirmed_tracks(1, Eigen::Vector2f(-5.0f, 3.0f), &forward);
  const int far4 = confirmed_tracks(4, Eigen::Vector2f(-5.0f, 3.0f), &forward);
  INFO("forward " << forward << "; kept with 1 / 4 levels: exact " << good1 << " / " << good4 << ", 1.1 px off " << near1
                  << " / " << near4 << ", 5.8 px off " << far1 << " / " << far4);
  REQUIRE(forward > 50);
  CHECK(good1 >= 0.95 * forward);
  CHECK(good1 >= good4 - 1);
  CHECK(near1 == 0);
  CHECK(near4 == 0);
  CHECK(far1 <= 0.02 * forward);
  CHECK(far4 <= 0.02 * forward);
}

TEST_CASE("KLT tracks a sub-pixel shift to a small fraction of a pixel") {
  const KltResult r = track_transformed(0.0, Eigen::Vector2d(1.37, -0.61), 4);
  INFO("tracked " << r.tracked << "/" << r.attempted << " rms " << r.rms_px << " px, max " << r.max_px);
  CHECK(r.tracked >= 0.95 * r.attempted);
  CHECK(r.rms_px < 0.05);
}

TEST_CASE("KLT on 4 levels tracks a 1 degree rotation plus a 7.3 px shift") {
  // 1 degree between frames is 20 deg/s at 20 Hz. A translation-only window absorbs the rotation
  // as a bias of about angle x the offset of the window's gradient energy from its centre
  // (3 degrees gives 0.21 px RMS here).
  const KltResult r = track_transformed(1.0 * M_PI / 180.0, Eigen::Vector2d(7.3, -4.6), 4);
  INFO("tracked " << r.tracked << "/" << r.attempted << " rms " << r.rms_px << " px, max " << r.max_px);
  CHECK(r.tracked >= 0.9 * r.attempted);
  CHECK(r.rms_px < 0.1);
}

TEST_CASE("a 40 px motion needs the pyramid: 1 level fails, 4 levels succeed, a good guess rescues 1 level") {
  // A 21 px window: with the default 15 px window the coarse levels' basin is too small for a
  // blind 40 px jump on this texture (the IMU prediction exists for that case). Without the
  // forward-backward check a few blind 4-level tracks lock onto a wrong blob (seen on aarch64).
  const Eigen::Vector2d shift(40.0, 12.0);
  const KltResult one = track_transformed(0.0, shift, 1, false, 21);
  const KltResult four = track_transformed(0.0, shift, 4, false, 21);
  const KltResult guided = track_transformed(0.0, shift, 1, /*use_truth_guess=*/true, 21);
  INFO("1 level: " << one.tracked << "/" << one.attempted << "; 4 levels: " << four.tracked << "/" << four.attempted
                   << " rms " << four.rms_px << "; guided 1 level: " << guided.tracked << "/" << guided.attempted
                   << " rms " << guided.rms_px);
  CHECK(one.accurate < 0.3 * one.attempted);
  CHECK(four.tracked >= 0.9 * four.attempted);
  CHECK(four.rms_px < 0.05);
  CHECK(guided.tracked >= 0.95 * guided.attempted);
  CHECK(guided.rms_px < 0.05);
}

TEST_CASE("sparse coarse levels track as the whole window does, and level 0 decides the precision") {
  // The coarse levels only carry the displacement into level 0's basin: iterating them on every
  // other pixel (a quarter of the samples) leaves the result to level 0's whole window. A sparse
  // level 0 as well keeps the tracks but loses some precision (a quarter of the samples).
  const Eigen::Vector2d shift(7.3, -4.6);
  const double angle = 1.0 * M_PI / 180.0;
  const int kNone = ums::KltOptions{}.sparse_from_level;
  const KltResult dense = track_transformed(angle, shift, 4, false, 15, kNone, kNone);
  const KltResult coarse = track_transformed(angle, shift, 4, false, 15, 1, kNone);
  const KltResult all = track_transformed(angle, shift, 4, false, 15, 0, kNone);
  INFO("tracked / rms px: dense " << dense.tracked << " / " << dense.rms_px << ", sparse from level 1 " << coarse.tracked
                                  << " / " << coarse.rms_px << ", sparse on every level " << all.tracked << " / "
                                  << all.rms_px << " (of " << dense.attempted << ")");
  CHECK(coarse.tracked >= dense.tracked - 1);
  CHECK(std::abs(coarse.rms_px - dense.rms_px) < 0.005);
  CHECK(all.tracked >= 0.9 * all.attempted);
  CHECK(all.rms_px < dense.rms_px + 0.01);
  // A 40 px jump (21 px window): the sparse coarse levels still find level 0's basin.
  const KltResult jump = track_transformed(0.0, Eigen::Vector2d(40.0, 12.0), 4, false, 21, 1, kNone);
  INFO("40 px jump, sparse from level 1: " << jump.tracked << "/" << jump.attempted << " rms " << jump.rms_px);
  CHECK(jump.tracked >= 0.9 * jump.attempted);
  CHECK(jump.rms_px < 0.05);
}

TEST_CASE("sparse confirmations keep the good tracks and drop displaced ones, as whole-window ones do") {
  int forward = 0;
  const int good = confirmed_tracks(4, Eigen::Vector2f::Zero(), &forward, 0);
  const int near = confirmed_tracks(4, Eigen::Vector2f(0.9f, -0.6f), &forward, 0);
  const int far = confirmed_tracks(4, Eigen::Vector2f(-5.0f, 3.0f), &forward, 0);
  INFO("forward " << forward << "; kept with sparse confirmations: exact " << good << ", 1.1 px off " << near
                  << ", 5.8 px off " << far);
  REQUIRE(forward > 50);
  CHECK(good >= 0.95 * forward);
  CHECK(near == 0);
  CHECK(far <= 0.02 * forward);
}

TEST_CASE("a level whose sparse window sees no texture iterates on the whole window") {
  // Single bright pixels at odd coordinates: a window centred on an odd pixel has its sparse
  // samples on even rows and columns, where every central difference is zero.
  const int w = 120, h = 100;
  auto dots = [&](int dx, int dy) {
    ums::test::GreyImage img(w, h, 40);
    for (int y = 3; y + dy < h; y += 6)
      for (int x = 1; x + dx < w; x += 10) img.pixels[static_cast<std::size_t>((y + dy) * w + x + dx)] = 220;
    return img;
  };
  const ums::test::GreyImage a = dots(0, 0), b = dots(1, 1);
  ums::ImagePyramid pa(w, h, 1), pb(w, h, 1);
  REQUIRE(pa.build(a.view()) == ums::Status::kOk);
  REQUIRE(pb.build(b.view()) == ums::Status::kOk);
  ums::KltOptions dense_opt, sparse_opt;
  sparse_opt.sparse_from_level = 0;
  const Eigen::Vector2f p0(61.0f, 51.0f);
  Eigen::Vector2f p_dense = p0 + Eigen::Vector2f(0.6f, 0.7f), p_sparse = p_dense;
  REQUIRE(ums::klt_track(pa, pb, 1, dense_opt, p0, &p_dense) == ums::Status::kOk);
  REQUIRE(ums::klt_track(pa, pb, 1, sparse_opt, p0, &p_sparse) == ums::Status::kOk);
  INFO("dense " << p_dense.transpose() << ", sparse " << p_sparse.transpose());
  CHECK(std::abs(p_dense.x() - 62.0f) < 0.01f);
  CHECK(std::abs(p_dense.y() - 52.0f) < 0.01f);
  CHECK(p_sparse.x() == p_dense.x());
  CHECK(p_sparse.y() == p_dense.y());
}

TEST_CASE("KLT refuses an untextured window") {
  ums::test::GreyImage flat(100, 80, 100);
  ums::ImagePyramid a(100, 80, 2), b(100, 80, 2);
  REQUIRE(a.build(flat.view()) == ums::Status::kOk);
  REQUIRE(b.build(flat.view()) == ums::Status::kOk);
  Eigen::Vector2f p(50.0f, 40.0f);
  CHECK(ums::klt_track(a, b, 2, ums::KltOptions{}, Eigen::Vector2f(50.0f, 40.0f), &p) == ums::Status::kNotConverged);
}

TEST_CASE("KltOptions::validate rejects an even window") {
  ums::KltOptions o;
  o.window_px = 20;
  CHECK_THROWS_AS(o.validate(), std::invalid_argument);
}

// The sampler's arithmetic written out sample by sample: the weights in 1/128 from the rounded
// fractions, the integer sum of products, the float quotient.
float fixed_point_reference(const ums::ImageView& v, float x, float y, int i, int j) {
  const float fx0 = std::floor(x), fy0 = std::floor(y);
  const int X = static_cast<int>((x - fx0) * 128.0f + 0.5f), Y = static_cast<int>((y - fy0) * 128.0f + 0.5f);
  const int w11 = (X * Y + 64) >> 7, w01 = X - w11, w10 = Y - w11, w00 = 128 - X - Y + w11;
  auto px = [&](int xx, int yy) {
    return static_cast<int>(v.row(std::clamp(yy, 0, v.height - 1))[std::clamp(xx, 0, v.width - 1)]);
  };
  const int x0 = static_cast<int>(fx0) + i, y0 = static_cast<int>(fy0) + j;
  const int sum = w00 * px(x0, y0) + w01 * px(x0 + 1, y0) + w10 * px(x0, y0 + 1) + w11 * px(x0 + 1, y0 + 1);
  return static_cast<float>(sum) / 128.0f;
}

// Float bilinear interpolation with exact weights (what the fixed-point weights approximate).
float exact_bilinear(const ums::ImageView& v, float x, float y) {
  const float fx0 = std::floor(x), fy0 = std::floor(y);
  const float ax = x - fx0, ay = y - fy0;
  auto px = [&](int xx, int yy) {
    return static_cast<float>(v.row(std::clamp(yy, 0, v.height - 1))[std::clamp(xx, 0, v.width - 1)]);
  };
  const int x0 = static_cast<int>(fx0), y0 = static_cast<int>(fy0);
  return (1.0f - ax) * (1.0f - ay) * px(x0, y0) + ax * (1.0f - ay) * px(x0 + 1, y0) + (1.0f - ax) * ay * px(x0, y0 + 1) +
         ax * ay * px(x0 + 1, y0 + 1);
}

TEST_CASE("bilinear patch sampling equals the fixed-point formula bit for bit, inside and at the border") {
  const int w = 80, h = 60;
  const ums::test::GreyImage img = ums::test::random_image(w, h, 88172645u);
  const ums::ImageView v = img.view();
  float out[33 * 33];
  int mismatches = 0, samples = 0;
  // Every remainder of the eight-sample kernel, the tracker's windows and larger; 9 .. 16 take
  // one 16-sample step a row, 16 with no row past the patch.
  const int sizes[10] = {1, 4, 5, 6, 7, 9, 15, 16, 17, 33};
  // Interior origins (integer, tiny and near-1 fractions too: 0.9999 rounds to the next pixel's
  // full weight), plus ones hanging over each edge (the copied block).
  const float origins[9][2] = {{3.25f, 4.75f}, {20.5f, 11.125f}, {40.9f, 20.01f}, {12.0f, 7.0f}, {5.0001f, 9.9999f},
                               {-2.3f, 5.5f},  {70.2f, 40.6f},   {10.0f, -1.5f},  {46.5f, 25.5f}};
  for (int n : sizes) {
    // In place, the kernel reads whole chunks of 8 and one pixel more: the origins where that
    // read ends exactly at the right edge (still in place) and one pixel further (copied); the
    // rows' n + 1 ending on the last row (walked by stride) and one row further (clamped).
    const int src = (n + 7) / 8 * 8 + 1;
    const float edge_x = static_cast<float>(w - src);
    const float edge_origins[4][2] = {{edge_x + 0.375f, 2.5f},
                                      {edge_x + 1.375f, 2.5f},
                                      {1.5f, static_cast<float>(h - n - 1) + 0.25f},
                                      {1.5f, static_cast<float>(h - n) + 0.25f}};
    for (int k = 0; k < 13; ++k) {
      const float* o = k < 9 ? origins[k] : edge_origins[k - 9];
      ums::sample_patch_bilinear(v, o[0], o[1], n, out);
      for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
          mismatches += out[j * n + i] != fixed_point_reference(v, o[0], o[1], i, j) ? 1 : 0;
          ++samples;
        }
      }
    }
  }
  INFO(samples << " samples");
  CHECK(samples == 13 * (1 + 16 + 25 + 36 + 49 + 81 + 225 + 256 + 289 + 1089));
  CHECK(mismatches == 0);
  // Beyond the stack rows it was sized for: refused, not overrun.
  CHECK_THROWS_AS(ums::sample_patch_bilinear(v, 3.0f, 3.0f, ums::KltOptions::kMaxWindowPx + 3, out), std::invalid_argument);
  CHECK_THROWS_AS(ums::sample_patch_bilinear(v, 3.0f, 3.0f, 0, out), std::invalid_argument);
}

TEST_CASE("sparse window samples equal the whole patch's on its even rows and columns, bit for bit") {
  const int w = 80, h = 60;
  const ums::test::GreyImage img = ums::test::random_image(w, h, 2463534242u);
  const ums::ImageView v = img.view();
  float out[16 * 16];
  int mismatches = 0, samples = 0;
  const int sizes[6] = {1, 3, 5, 8, 9, 16};
  const float origins[7][2] = {{3.25f, 4.75f}, {20.5f, 11.125f}, {12.0f, 7.0f}, {5.0001f, 9.9999f},
                               {-2.3f, 5.5f},  {60.2f, 30.6f},   {10.0f, -1.5f}};
  for (int n : sizes) {
    // In place the kernel reads whole chunks of 16 pixels and 2n rows: origins where those reads
    // end exactly at the right or bottom edge (in place) and one pixel further (copied rows).
    const int src = (n + 7) / 8 * 16;
    const float ex = static_cast<float>(w - src), ey = static_cast<float>(h - 2 * n);
    const float edge_origins[4][2] = {{ex + 0.375f, 2.5f}, {ex + 1.375f, 2.5f}, {1.5f, ey + 0.25f}, {1.5f, ey + 1.25f}};
    for (int k = 0; k < 11; ++k) {
      const float* o = k < 7 ? origins[k] : edge_origins[k - 7];
      ums::sample_sparse_bilinear(v, o[0], o[1], n, out);
      for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
          mismatches += out[j * n + i] != fixed_point_reference(v, o[0], o[1], 2 * i, 2 * j) ? 1 : 0;
          ++samples;
        }
      }
    }
  }
  CHECK(samples == 11 * (1 + 9 + 25 + 64 + 81 + 256));
  CHECK(mismatches == 0);
  CHECK_THROWS_AS(ums::sample_sparse_bilinear(v, 3.0f, 3.0f, ums::KltOptions::kMaxWindowPx / 2 + 2, out), std::invalid_argument);
  CHECK_THROWS_AS(ums::sample_sparse_bilinear(v, 3.0f, 3.0f, 0, out), std::invalid_argument);
}

TEST_CASE("fixed-point bilinear samples stay within half a grey level of exact bilinear interpolation on a textured image") {
  // The weights are rounded to 1/128: the position moves by at most 1/256 px per axis and the
  // cross term's weight by 1/256, so a sample moves by a small fraction of the local contrast.
  const ums::test::BlobTexture tex(320, 240, 400, 777u);
  const ums::test::GreyImage img = tex.render(320, 240);
  const ums::ImageView v = img.view();
  float out[15 * 15];
  double max_err = 0.0, sum_err = 0.0;
  int samples = 0;
  std::uint32_t s = 12345u;
  for (int k = 0; k < 200; ++k) {
    s = s * 1664525u + 1013904223u;
    const float x = 10.0f + static_cast<float>(s >> 8) / 16777216.0f * 290.0f;
    s = s * 1664525u + 1013904223u;
    const float y = 10.0f + static_cast<float>(s >> 8) / 16777216.0f * 210.0f;
    ums::sample_patch_bilinear(v, x, y, 15, out);
    for (int j = 0; j < 15; ++j) {
      for (int i = 0; i < 15; ++i) {
        const double e = static_cast<double>(std::abs(out[j * 15 + i] - exact_bilinear(v, x + static_cast<float>(i), y + static_cast<float>(j))));
        max_err = std::max(max_err, e);
        sum_err += e;
        ++samples;
      }
    }
  }
  INFO("max " << max_err << " grey, mean " << sum_err / samples << " grey over " << samples << " samples");
  CHECK(max_err <= 0.5);
  CHECK(sum_err / samples <= 0.03);
}

TEST_CASE("a sparse level without a cached template samples its grid directly: the same tracks as from the dense template") {
  // The stereo confirmations keep no template: their sparse levels sample the sparse grid alone
  // (sparse_template_direct). With a cache slot every level goes through the dense template and
  // its decimation. Both give the same samples and gradients, so the same tracks bit for bit, at
  // every window size, near the image edges (the dense path there) and at the last positions the
  // direct path takes. (With the default texture floor 2 of these 2212 tracks differ, near the
  // bottom edge: the texture tests differ, the next test.)
  const Scene sc(1.0 * M_PI / 180.0, Eigen::Vector2d(7.3, -4.6));
  REQUIRE(sc.n > 50);
  int compared = 0, differ = 0, ok = 0;
  for (int window = 5; window <= ums::KltOptions::kMaxWindowPx; window += 2) {
    ums::KltOptions opt;
    opt.window_px = window;
    opt.sparse_from_level = 0;
    // The two paths' texture tests differ (the next test); with a floor this low both pass
    // wherever the window has any texture, so only the samples and the iterations are compared.
    opt.min_eigen = 1e-3f;
    const int levels = window <= 21 ? 4 : 2;  // the 4th level (80 x 60) holds a 21 px window
    ums::KltTemplateCache cache(1, 4, ums::klt_template_units(window));
    // Where the direct sampling reaches the right and bottom image edges at level 0: the patch
    // (window + 2 samples a side) read in 8-sample chunks, its even rows in 16-byte pairs.
    const int half = window / 2, ne = window + 2, side = half + 1;
    const int last_byte = std::max((ne + 7) / 8 * 8, 2 * ((side + 7) / 8 * 8));
    const Eigen::Vector2f edge(static_cast<float>(Scene::kW - 1 - last_byte + half + 1) + 0.25f,
                               static_cast<float>(Scene::kH - 1 - ne + half + 1) + 0.25f);
    // The corners, points 1.3 px to 3.6 px from the image edges, and the last positions the
    // direct sampling takes (and one pixel further).
    for (int i = 0; i < sc.n + 8; ++i) {
      Eigen::Vector2f from;
      if (i < sc.n) {
        from = sc.pts[i];
      } else if (i < sc.n + 4) {
        from = Eigen::Vector2f(i % 2 == 0 ? 1.3f : Scene::kW - 3.6f, i % 4 < 2 ? 2.4f : Scene::kH - 1.8f);
      } else {
        const int k = i - sc.n - 4;
        from = edge + Eigen::Vector2f(k % 2 == 0 ? 0.0f : 1.0f, k < 2 ? -100.0f : 0.0f);
        if (k >= 2) from.x() -= 100.0f * static_cast<float>(k - 2);
      }
      Eigen::Vector2f direct = from, dense = from;
      const ums::Status s_direct = ums::klt_track(sc.pa, sc.pb, levels, opt, from, &direct);
      const ums::Status s_dense = ums::klt_track(sc.pa, sc.pb, levels, opt, from, &dense, &cache, 0);
      ++compared;
      ok += s_direct == ums::Status::kOk ? 1 : 0;
      const bool d = s_direct != s_dense || (s_direct == ums::Status::kOk && !(direct == dense));
      differ += d ? 1 : 0;
    }
  }
  INFO(compared << " tracks compared, " << ok << " tracked");
  CHECK(ok > compared / 2);
  CHECK(differ == 0);
}

TEST_CASE("without a cached template a sparse level tests the texture of its sparse grid, with one the whole window's") {
  // Bright columns x = 1 (mod 4) and rows y = 1 (mod 4) on a dark ground: the central
  // differences are +-20 grey/px at the even columns of the dark rows (and at the even rows of
  // the dark columns), 0 elsewhere. A 15 px window at an odd integer point has its sparse grid on
  // even pixels, where every sample sees both gradients: mean tensor 400 (grey/px)^2 on the grid,
  // about 156 over the whole window. With min_eigen 250 the same track is refused through a cache
  // slot (the whole window's test) and kept without one (the sparse grid's): the direct path runs.
  const int w = 64, h = 64;
  ums::test::GreyImage img(w, h, 60);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (x % 4 == 1 || y % 4 == 1) img.at(x, y) = 100;
  ums::ImagePyramid pa(w, h, 1), pb(w, h, 1);
  REQUIRE(pa.build(img.view()) == ums::Status::kOk);
  REQUIRE(pb.build(img.view()) == ums::Status::kOk);
  ums::KltOptions opt;
  opt.sparse_from_level = 0;
  opt.min_eigen = 250.0f;
  ums::KltTemplateCache cache(1, 1, ums::klt_template_units(opt.window_px));
  const Eigen::Vector2f from(31.0f, 33.0f);
  Eigen::Vector2f direct = from, dense = from;
  CHECK(ums::klt_track(pa, pb, 1, opt, from, &direct) == ums::Status::kOk);
  CHECK((direct - from).norm() < 0.01f);
  CHECK(ums::klt_track(pa, pb, 1, opt, from, &dense, &cache, 0) == ums::Status::kNotConverged);
  // Below both means both keep it, at the same place (a new cache: a slot keeps its texture verdict).
  opt.min_eigen = 100.0f;
  ums::KltTemplateCache cache2(1, 1, ums::klt_template_units(opt.window_px));
  direct = from;
  dense = from;
  CHECK(ums::klt_track(pa, pb, 1, opt, from, &direct) == ums::Status::kOk);
  CHECK(ums::klt_track(pa, pb, 1, opt, from, &dense, &cache2, 0) == ums::Status::kOk);
  CHECK(direct == dense);
}

// img inside a larger image whose extra columns and rows repeat its last column and row.
ums::test::GreyImage extended(const ums::test::GreyImage& img, int extra) {
  ums::test::GreyImage out(img.width + extra, img.height + extra);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x)
      out.at(x, y) = img.pixels[static_cast<std::size_t>(std::min(y, img.height - 1)) * img.width + std::min(x, img.width - 1)];
  return out;
}

TEST_CASE("KLT iterations take the same samples and sums whether the window is read in place, from the margin, or copied at the edge") {
  // Every sample any window takes is the same in the image and in its extension. By the right and
  // bottom edges the windows of the image's pyramid without a margin are copied (the sampler would
  // read past the edge) and sampled and summed apart; those of the pyramid with a margin read it
  // in place, as the extension's are, summed in the same pass, whose rows carry 16 - n samples
  // past a 9..15 px window to mask out: the same tracks, bit for bit, all three.
  // Windows 9 to 15 px (1 to 7 lanes kept of the second vector), templates sampled each time or
  // kept in a cache block (read up to its spare lanes); the sparse windows (8 samples a row at
  // 15 px) always from a cache: without one, a sparse template by the edge is cut from the whole
  // one and tested as it, which can differ from the direct sparse template away from the edge
  // (klt_tracker.hpp, sparse_from_level).
  const int w = 160, h = 120;
  const ums::test::BlobTexture tex(w, h, 140, 4242u);
  const Eigen::Vector2d pivot(w / 2.0, h / 2.0);
  const ums::test::GreyImage a = tex.render(w, h), b = tex.render(w, h, 0.0, Eigen::Vector2d(0.6, -0.45), pivot);
  const ums::test::GreyImage ea = extended(a, 40), eb = extended(b, 40);
  ums::ImagePyramid pa(w, h, 1, 0), pb(w, h, 1, 0), pea(w + 40, h + 40, 1), peb(w + 40, h + 40, 1);
  ums::ImagePyramid pma(w, h, 1), pmb(w, h, 1);
  REQUIRE(pma.level(0).margin == ums::capacity::kPyramidMarginPx);
  REQUIRE(pa.build(a.view()) == ums::Status::kOk);
  REQUIRE(pb.build(b.view()) == ums::Status::kOk);
  REQUIRE(pma.build(a.view()) == ums::Status::kOk);
  REQUIRE(pmb.build(b.view()) == ums::Status::kOk);
  REQUIRE(pea.build(ea.view()) == ums::Status::kOk);
  REQUIRE(peb.build(eb.view()) == ums::Status::kOk);
  struct Mode {
    int sparse_from;
    bool cached;
  };
  const Mode modes[3] = {{ums::capacity::kMaxPyramidLevels, false}, {ums::capacity::kMaxPyramidLevels, true}, {0, true}};
  int tracks = 0, tracked = 0, differ = 0, differ_margin = 0;
  for (const int window : {9, 11, 13, 15}) {
    for (const Mode& mode : modes) {
      ums::KltOptions opt;
      opt.window_px = window;
      opt.sparse_from_level = mode.sparse_from;
      // Window origins one pixel either side of where the image's sampler copies (right: x0 + 17 > w
      // whole, x0 + 16 > w sparse; bottom: y0 + n >= h), and inside; x0 = floor(x - half).
      const float edge = static_cast<float>(17 - window / 2);
      std::vector<Eigen::Vector2f> starts;
      for (float t = 12.0f; t < 100.0f; t += 6.3f) {
        for (const float d : {-1.9f, -1.4f, -0.7f, -0.2f, 0.4f, 1.7f}) {
          starts.emplace_back(static_cast<float>(w) - edge - d, t);
          starts.emplace_back(t + 20.0f, static_cast<float>(h) - edge - d);
        }
      }
      const int n = static_cast<int>(starts.size());
      ums::KltTemplateCache cache_img(n, 1, ums::klt_template_units(opt.window_px));
      ums::KltTemplateCache cache_ext(n, 1, ums::klt_template_units(opt.window_px));
      ums::KltTemplateCache cache_margin(n, 1, ums::klt_template_units(opt.window_px));
      for (int i = 0; i < n; ++i) {
        const Eigen::Vector2f& p = starts[static_cast<std::size_t>(i)];
        Eigen::Vector2f q_img = p, q_ext = p, q_margin = p;
        const ums::Status s_img = ums::klt_track(pa, pb, 1, opt, p, &q_img, mode.cached ? &cache_img : nullptr, i);
        const ums::Status s_ext = ums::klt_track(pea, peb, 1, opt, p, &q_ext, mode.cached ? &cache_ext : nullptr, i);
        const ums::Status s_margin =
            ums::klt_track(pma, pmb, 1, opt, p, &q_margin, mode.cached ? &cache_margin : nullptr, i);
        ++tracks;
        tracked += s_img == ums::Status::kOk ? 1 : 0;
        differ += s_img != s_ext || (s_img == ums::Status::kOk && (q_img.x() != q_ext.x() || q_img.y() != q_ext.y())) ? 1 : 0;
        differ_margin +=
            s_margin != s_ext || (s_ext == ums::Status::kOk && (q_margin.x() != q_ext.x() || q_margin.y() != q_ext.y())) ? 1 : 0;
      }
    }
  }
  INFO(tracked << " of " << tracks << " tracked");
  CHECK(tracks == 4 * 3 * 14 * 12);
  CHECK(tracked > tracks / 2);
  CHECK(differ == 0);
  CHECK(differ_margin == 0);
}
