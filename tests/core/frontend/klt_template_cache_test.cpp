#include "core/frontend/klt_template_cache.hpp"

#include <cstdint>
#include <cstring>
#include <stdexcept>

#include <catch2/catch.hpp>

#include "core/frontend/klt_tracker.hpp"
#include "profiling/alloc_counter.hpp"
#include "tests/core/frontend/synthetic_images.hpp"

namespace {

constexpr int kW = 320, kH = 240;

bool same_bits(const Eigen::Vector2f& a, const Eigen::Vector2f& b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Two renderings of one blob field, the second turned by 2 degrees and shifted, and a grid of
// start points (sub-pixel) over the first.
struct Pair {
  Pair() : pa(kW, kH, 4), pb(kW, kH, 4) {
    const ums::test::BlobTexture tex(kW, kH, 500, 777u);
    a = std::make_unique<ums::test::GreyImage>(tex.render(kW, kH));
    b = std::make_unique<ums::test::GreyImage>(
        tex.render(kW, kH, 0.035, Eigen::Vector2d(3.3, -2.1), Eigen::Vector2d(kW / 2.0, kH / 2.0)));
    REQUIRE(pa.build(a->view()) == ums::Status::kOk);
    REQUIRE(pb.build(b->view()) == ums::Status::kOk);
    for (int j = 0; j < 6; ++j)
      for (int i = 0; i < 8; ++i) pts[n++] = Eigen::Vector2f(20.3f + 38.1f * i, 17.7f + 40.3f * j);
  }
  std::unique_ptr<ums::test::GreyImage> a, b;
  ums::ImagePyramid pa, pb;
  Eigen::Vector2f pts[48];
  int n = 0;
};

// klt_track from every point, without a cache, and (twice) with one: slot per point.
struct Runs {
  ums::Status s = ums::Status::kOk;
  Eigen::Vector2f p = Eigen::Vector2f::Zero();
};

Runs track(const Pair& pr, int i, int levels, ums::KltTemplateCache* cache, int slot) {
  Runs r;
  r.p = pr.pts[i];
  r.s = ums::klt_track(pr.pa, pr.pb, levels, ums::KltOptions{}, pr.pts[i], &r.p, cache, slot);
  return r;
}

}  // namespace

TEST_CASE("klt_track with a template cache gives the same bits as without, on a miss and on a hit") {
  const Pair pr;
  const ums::KltOptions opt;
  ums::KltTemplateCache cache(pr.n, 2, ums::klt_template_units(opt.window_px));
  int ok = 0;
  for (int levels : {2, 4, 1}) {
    for (int i = 0; i < pr.n; ++i) {
      const Runs plain = track(pr, i, levels, nullptr, -1);
      const Runs miss = track(pr, i, levels, &cache, i);  // levels 0-1 filled here (or re-used)
      bool filled = false;
      REQUIRE(cache.block(i, pr.pa, pr.pts[i], 0, &filled) != nullptr);
      CHECK(filled);
      const Runs hit = track(pr, i, levels, &cache, i);
      CHECK(plain.s == miss.s);
      CHECK(plain.s == hit.s);
      if (plain.s != ums::Status::kOk) continue;
      ++ok;
      CHECK(same_bits(plain.p, miss.p));
      CHECK(same_bits(plain.p, hit.p));
    }
  }
  CHECK(ok > 100);  // of 144: the comparison is over real tracks
}

TEST_CASE("a template cache slot holding another point, or a rebuilt pyramid, is re-keyed, not read") {
  Pair pr;
  const ums::KltOptions opt;
  ums::KltTemplateCache cache(1, 2, ums::klt_template_units(opt.window_px));
  // One slot for every point: each call finds the previous point's templates there.
  for (int i = 0; i < pr.n; ++i) {
    const Runs plain = track(pr, i, 2, nullptr, -1);
    const Runs shared = track(pr, i, 2, &cache, 0);
    CHECK(plain.s == shared.s);
    if (plain.s == ums::Status::kOk) CHECK(same_bits(plain.p, shared.p));
  }
  // The same point after the pyramid is rebuilt from the other image: the slot's key (address
  // and build count) no longer matches.
  bool filled = false;
  cache.block(0, pr.pa, pr.pts[5], 0, &filled);
  const Runs before = track(pr, 5, 2, &cache, 0);
  const std::uint64_t gen = pr.pa.generation();
  REQUIRE(pr.pa.build(pr.b->view()) == ums::Status::kOk);
  CHECK(pr.pa.generation() == gen + 1);
  cache.block(0, pr.pa, pr.pts[5], 0, &filled);
  CHECK_FALSE(filled);
  const Runs after_cached = track(pr, 5, 2, &cache, 0);
  const Runs after_plain = track(pr, 5, 2, nullptr, -1);
  CHECK(after_cached.s == after_plain.s);
  if (after_plain.s == ums::Status::kOk) CHECK(same_bits(after_cached.p, after_plain.p));
  // Tracking an image into itself moves the point by less than the tracker's tolerance; the
  // first image's result moved it by the shift (about 4 px).
  if (after_plain.s == ums::Status::kOk) CHECK((after_plain.p - pr.pts[5]).norm() < 0.05f);
  if (before.s == ums::Status::kOk) CHECK((before.p - pr.pts[5]).norm() > 2.0f);
}

TEST_CASE("a template cache refuses empty sizes and answers nullptr outside its slots and levels") {
  CHECK_THROWS_AS(ums::KltTemplateCache(0, 2, 100), std::invalid_argument);
  CHECK_THROWS_AS(ums::KltTemplateCache(4, 0, 100), std::invalid_argument);
  CHECK_THROWS_AS(ums::KltTemplateCache(4, 2, 0), std::invalid_argument);
  ums::KltTemplateCache cache(4, 2, 100);
  ums::ImagePyramid pyr(64, 48, 4);
  bool filled = true;
  CHECK(cache.block(4, pyr, Eigen::Vector2f(3.0f, 4.0f), 0, &filled) == nullptr);
  CHECK_FALSE(filled);
  CHECK(cache.block(-1, pyr, Eigen::Vector2f(3.0f, 4.0f), 0, &filled) == nullptr);
  CHECK(cache.block(0, pyr, Eigen::Vector2f(3.0f, 4.0f), 2, &filled) == nullptr);
  std::int16_t* b0 = cache.block(0, pyr, Eigen::Vector2f(3.0f, 4.0f), 1, &filled);
  REQUIRE(b0 != nullptr);
  CHECK_FALSE(filled);
  cache.mark_filled(0, 1);
  CHECK(cache.block(0, pyr, Eigen::Vector2f(3.0f, 4.0f), 1, &filled) == b0);
  CHECK(filled);
  // A position one float step away is another point.
  CHECK(cache.block(0, pyr, Eigen::Vector2f(std::nextafter(3.0f, 4.0f), 4.0f), 1, &filled) == b0);
  CHECK_FALSE(filled);
}

TEST_CASE("klt_track through a template cache allocates nothing") {
  const Pair pr;
  ums::KltTemplateCache cache(pr.n, 2, ums::klt_template_units(ums::KltOptions{}.window_px));
  ums::AllocScope scope;
  for (int i = 0; i < pr.n; ++i) {
    track(pr, i, 4, &cache, i);
    track(pr, i, 4, &cache, i);
  }
  const std::uint64_t allocs = scope.allocations();
  if (ums::alloc_counter_available()) CHECK(allocs == 0);
}
