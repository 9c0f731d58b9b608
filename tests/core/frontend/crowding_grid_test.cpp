#include "core/frontend/crowding_grid.hpp"

#include <cmath>
#include <cstdint>
#include <memory>
#include <random>
#include <vector>

#include <catch2/catch.hpp>

#include "core/frontend/corner_detector.hpp"
#include "profiling/alloc_counter.hpp"

namespace {

// Thins `tracks` as the front end does (each is kept when free, then blocks its disk), once with
// the detector's mask and once with the grid, and counts where the two disagree: on the kept set,
// and on every pixel of the image afterwards (and points just outside it).
struct Disagreement {
  int kept = 0;      // tracks kept by the mask
  int kept_differ = 0;
  int pixels_differ = 0;
};

Disagreement compare(int w, int h, float r, const std::vector<Eigen::Vector2f>& tracks) {
  ums::CornerDetector det(w, h);
  auto grid = std::make_unique<ums::CrowdingGrid>();
  det.clear_mask();
  grid->reset(w, h, r);
  Disagreement d;
  for (const Eigen::Vector2f& p : tracks) {
    const bool mask_free = det.is_free(p);
    const bool grid_free = grid->is_free(p);
    d.kept += mask_free ? 1 : 0;
    d.kept_differ += mask_free != grid_free ? 1 : 0;
    if (mask_free) {
      det.block_disk(p, r);
      grid->add(p);
    }
  }
  for (int y = -2; y < h + 2; ++y)
    for (int x = -2; x < w + 2; ++x) {
      const Eigen::Vector2f p(static_cast<float>(x), static_cast<float>(y));
      d.pixels_differ += det.is_free(p) != grid->is_free(p) ? 1 : 0;
    }
  return d;
}

}  // namespace

TEST_CASE("The crowding grid keeps the tracks the detector's mask keeps, and frees the same pixels") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  // Radii of the option's range (1..200 px), fractional ones included; tracks anywhere in the
  // image and up to 3 px outside it, half of them on exact or half pixels (the rounding edges).
  const float radii[] = {1.0f, 2.5f, 7.3f, 25.0f, 30.0f, 61.7f, 200.0f};
  const int sizes[][2] = {{752, 480}, {848, 480}, {97, 61}};
  for (const auto& size : sizes) {
    for (float r : radii) {
      const int w = size[0], h = size[1];
      std::vector<Eigen::Vector2f> tracks;
      for (int i = 0; i < 400; ++i) {
        float x = -3.0f + unit(rng) * static_cast<float>(w + 6), y = -3.0f + unit(rng) * static_cast<float>(h + 6);
        if (i % 2 == 0) {
          x = std::round(2.0f * x) * 0.5f;
          y = std::round(2.0f * y) * 0.5f;
        }
        tracks.emplace_back(x, y);
      }
      const Disagreement d = compare(w, h, r, tracks);
      INFO("image " << w << "x" << h << ", radius " << r << " px, kept " << d.kept);
      CHECK(d.kept > 0);
      CHECK(d.kept < 400);  // some tracks were crowded out: the test sees both answers
      CHECK(d.kept_differ == 0);
      CHECK(d.pixels_differ == 0);
    }
  }
}

TEST_CASE("The crowding grid ignores non-finite centres and refuses disks beyond its capacity") {
  auto grid = std::make_unique<ums::CrowdingGrid>();
  grid->reset(752, 480, 1.0f);
  const float nan = std::nanf("");
  CHECK(grid->add(Eigen::Vector2f(nan, 10.0f)));
  CHECK(grid->size() == 0);
  CHECK(grid->is_free(Eigen::Vector2f(10.0f, 10.0f)));
  CHECK_FALSE(grid->is_free(Eigen::Vector2f(-0.6f, 10.0f)));  // rounds to x = -1: outside the image
  CHECK(grid->is_free(Eigen::Vector2f(-0.4f, 10.0f)));        // rounds to x = 0
  const int cap = static_cast<int>(ums::capacity::kMaxFeaturesPerCamera);
  ums::AllocScope scope;
  for (int i = 0; i < cap; ++i) REQUIRE(grid->add(Eigen::Vector2f(static_cast<float>(i % 370) * 2.0f, static_cast<float>(i / 370) * 3.0f)));
  if (ums::alloc_counter_available()) CHECK(scope.allocations() == 0);
  CHECK_FALSE(grid->add(Eigen::Vector2f(700.0f, 400.0f)));
  CHECK(grid->size() == cap);
  CHECK(grid->is_free(Eigen::Vector2f(700.0f, 400.0f)));  // the refused disk blocks nothing
  CHECK_FALSE(grid->is_free(Eigen::Vector2f(2.0f, 3.0f)));
}
