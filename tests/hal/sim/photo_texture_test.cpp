#include "hal/sim/photo_texture.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "tests/common/test_paths.hpp"
#include "tests/common/emulation.hpp"

using namespace ums::sim;

namespace {

const PhotoSource& euroc_micro_source() {
  static const PhotoSource source = load_photo_source(ums::test::euroc_micro_dir());
  return source;
}

// Gradient statistics of a grey image: median std over 32x32 blocks (local contrast) and the
// share of pixels whose |dx| + |dy| exceeds 24 DN (strong edges and corners).
struct GradientStats {
  double block_std = 0.0;
  double strong_share = 0.0;
};

GradientStats gradient_stats(const std::uint8_t* px, int w, int h) {
  std::vector<double> stds;
  for (int by = 0; by + 32 <= h; by += 32) {
    for (int bx = 0; bx + 32 <= w; bx += 32) {
      double s = 0.0, s2 = 0.0;
      for (int y = by; y < by + 32; ++y)
        for (int x = bx; x < bx + 32; ++x) {
          const double v = px[static_cast<std::size_t>(y) * w + x];
          s += v;
          s2 += v * v;
        }
      stds.push_back(std::sqrt(std::max(0.0, s2 / 1024.0 - (s / 1024.0) * (s / 1024.0))));
    }
  }
  std::sort(stds.begin(), stds.end());
  long strong = 0;
  for (int y = 0; y + 1 < h; ++y)
    for (int x = 0; x + 1 < w; ++x) {
      const int c = px[static_cast<std::size_t>(y) * w + x];
      strong += std::abs(px[static_cast<std::size_t>(y) * w + x + 1] - c) + std::abs(px[static_cast<std::size_t>(y + 1) * w + x] - c) > 24;
    }
  return {stds[stds.size() / 2], static_cast<double>(strong) / (static_cast<double>(w - 1) * (h - 1))};
}

GradientStats source_stats(const PhotoSource& src) {
  GradientStats sum;
  int n = 0;
  for (std::size_t i = 0; i < src.frames.size(); i += 9) {
    const GradientStats s = gradient_stats(src.frames[i].pixels.data(), src.frames[i].width, src.frames[i].height);
    sum.block_std += s.block_std;
    sum.strong_share += s.strong_share;
    ++n;
  }
  return {sum.block_std / n, sum.strong_share / n};
}

// Mean squared gradient across the cell boundaries (texel pairs whose nearest patch centres
// differ: where a hard cut puts an edge) divided by the mean over the whole texture.
double seam_energy_ratio(const Texture& t, const std::vector<MosaicPatch>& layout, int grid_px) {
  const int n = t.size, mask = n - 1, cells = n / grid_px;
  auto wrap = [&](int d) {
    d &= mask;
    return d >= n / 2 ? d - n : d;
  };
  std::vector<int> owner(static_cast<std::size_t>(n) * n);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      int best = -1;
      long best_d2 = 0;
      for (int j = -2; j <= 2; ++j)
        for (int i = -2; i <= 2; ++i) {
          const int k = ((y / grid_px + j + cells) % cells) * cells + (x / grid_px + i + cells) % cells;
          const long dx = wrap(x - layout[static_cast<std::size_t>(k)].cx), dy = wrap(y - layout[static_cast<std::size_t>(k)].cy);
          if (best < 0 || dx * dx + dy * dy < best_d2) {
            best = k;
            best_d2 = dx * dx + dy * dy;
          }
        }
      owner[static_cast<std::size_t>(y) * n + x] = best;
    }
  const auto& m = t.mips[0];
  double all = 0.0, seam = 0.0;
  long seams = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * n + x;
      const std::size_t r = static_cast<std::size_t>(y) * n + ((x + 1) & mask), b = static_cast<std::size_t>((y + 1) & mask) * n + x;
      const double gx = m[r] - m[i], gy = m[b] - m[i];
      all += gx * gx + gy * gy;
      if (owner[i] != owner[r]) {
        seam += 2.0 * gx * gx;  // the difference across the boundary, per direction as in `all`
        ++seams;
      }
      if (owner[i] != owner[b]) {
        seam += 2.0 * gy * gy;
        ++seams;
      }
    }
  return seam / static_cast<double>(seams) / (all / (static_cast<double>(n) * n));
}

}  // namespace

TEST_CASE("photo source: both cameras of the EuRoC micro dataset, a clear error otherwise", "[sim][photo_texture]") {
  const PhotoSource& src = euroc_micro_source();
  CHECK(src.cam0_frames == 95);
  CHECK(src.frames.size() == 190u);
  CHECK(src.frames.front().width == 752);
  CHECK(src.frames.back().height == 480);
  try {
    load_photo_source("/nonexistent/dataset");
    FAIL("no exception");
  } catch (const std::runtime_error& e) {
    CHECK(std::string(e.what()).find("/nonexistent/dataset/mav0/cam0/data") != std::string::npos);
  }
}

// Acceptance: a photo material has the gradient statistics of the real images it is cut from
// (local contrast and share of strong gradients within a factor ~1.4 of the source's), not
// those of value noise.
TEST_CASE("photo material: real-image gradient statistics", "[sim][photo_texture]") {
  const PhotoSource& src = euroc_micro_source();
  const GradientStats real = source_stats(src);
  const Texture t = make_photo_material(src, 3, PhotoMaterialOptions{});
  REQUIRE(t.size == 1024);
  const GradientStats tex = gradient_stats(t.mips[0].data(), t.size, t.size);
  WARN("source: block std " << real.block_std << " DN, strong share " << real.strong_share << "; material: block std "
                            << tex.block_std << " DN, strong share " << tex.strong_share);
  CHECK(tex.block_std / real.block_std > 0.7);
  CHECK(tex.block_std / real.block_std < 1.4);
  CHECK(tex.strong_share / real.strong_share > 0.6);
  CHECK(tex.strong_share / real.strong_share < 1.5);
  // Texels are not clipped: the brightness offsets and contrast gains stay inside 0..255.
  const long clipped = std::count_if(t.mips[0].begin(), t.mips[0].end(), [](std::uint8_t v) { return v == 0 || v == 255; });
  CHECK(static_cast<double>(clipped) / static_cast<double>(t.mips[0].size()) < 0.02);
}

// Acceptance: no grid of seams. The gradient energy across the cell boundaries is that of the
// texture elsewhere with the cross-fade, and clearly higher with hard cuts (the metric's control).
TEST_CASE("photo material: feathered seams carry no extra gradient energy", "[sim][photo_texture]") {
  if (ums::test::skip_heavy_under_emulation()) return;
  const PhotoSource& src = euroc_micro_source();
  PhotoMaterialOptions o;
  std::vector<MosaicPatch> layout;
  const Texture feathered = make_photo_material(src, 4, o, &layout);
  REQUIRE(layout.size() == 64u);  // (1024 / 128)^2 cells
  o.feather = false;
  std::vector<MosaicPatch> hard_layout;
  const Texture hard = make_photo_material(src, 4, o, &hard_layout);
  const double r_feathered = seam_energy_ratio(feathered, layout, o.grid_px);
  const double r_hard = seam_energy_ratio(hard, hard_layout, o.grid_px);
  WARN("seam / overall gradient energy: feathered " << r_feathered << ", hard-edged " << r_hard);
  CHECK(r_feathered < 1.15);
  CHECK(r_hard > 1.5);
}

TEST_CASE("photo material: deterministic per seed, patches as configured", "[sim][photo_texture]") {
  const PhotoSource& src = euroc_micro_source();
  PhotoMaterialOptions o;
  o.size = 512;
  std::vector<MosaicPatch> layout;
  const Texture a = make_photo_material(src, 9, o, &layout);
  const Texture b = make_photo_material(src, 9, o);
  const Texture c = make_photo_material(src, 10, o);
  CHECK(a.mips[0] == b.mips[0]);
  CHECK(a.mips[0] != c.mips[0]);
  CHECK(a.mips.size() == 10u);  // 512 .. 1
  REQUIRE(layout.size() == 16u);  // (512 / 128)^2
  for (const MosaicPatch& p : layout) {
    CHECK(p.size >= 288);
    CHECK(p.size <= 320);
  }
  o.grid_px = 96;  // 512 is not a multiple of 96
  std::string err;
  CHECK_FALSE(o.validate(&err));
  CHECK_THROWS(make_photo_material(src, 1, o));
}
