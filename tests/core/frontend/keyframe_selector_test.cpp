#include "core/frontend/keyframe_selector.hpp"

#include <catch2/catch.hpp>

#include "profiling/alloc_counter.hpp"

namespace {

// n features with ids 0..n-1, all 3D, left points shifted by dx (normalized units).
void make_frame(ums::FrameFeatures* f, std::int64_t t_ns, int n, float dx, int n3d) {
  f->clear();
  f->t_ns = t_ns;
  for (int i = 0; i < n; ++i) {
    ums::FeatureObservation o;
    o.id = static_cast<std::uint32_t>(i);
    o.cls = i < n3d ? ums::FeatureClass::k3D : ums::FeatureClass::k2DLeft;
    o.xy_left = Eigen::Vector2f(0.01f * static_cast<float>(i) + dx, -0.2f);
    o.xy_right = o.xy_left;
    f->features.push_back(o);
  }
  f->n_3d = n3d;
  f->n_2d_left = n - n3d;
}

}  // namespace

TEST_CASE("keyframe: first frame, then parallax, interval and depth-feature rules fire independently") {
  ums::KeyframeOptions opt;  // 0.5 s, 10 px at 460 px, 40 depth features, 20 shared
  ums::KeyframeSelector sel(opt);
  ums::FrameFeatures f;
  make_frame(&f, 0, 100, 0.0f, 100);
  auto d = sel.update(f, 0);
  CHECK(d.is_keyframe);
  CHECK((d.reasons & ums::kKeyframeFirst) != 0);

  // 5 px of parallax at 460 px: not a keyframe.
  make_frame(&f, 50'000'000, 100, 5.0f / 460.0f, 100);
  d = sel.update(f, 0);
  CHECK_FALSE(d.is_keyframe);
  CHECK(d.shared_features == 100);
  CHECK(d.mean_parallax_px == Approx(5.0f).epsilon(1e-3));

  // 12 px: parallax keyframe.
  make_frame(&f, 100'000'000, 100, 12.0f / 460.0f, 100);
  d = sel.update(f, 0);
  CHECK(d.is_keyframe);
  CHECK(d.reasons == ums::kKeyframeParallax);

  // Still camera, 0.6 s later: interval keyframe.
  make_frame(&f, 700'000'000, 100, 12.0f / 460.0f, 100);
  d = sel.update(f, 0);
  CHECK(d.reasons == ums::kKeyframeInterval);

  // Few 3D features but the estimator reports enough 2D features with depth: no keyframe.
  make_frame(&f, 750'000'000, 100, 12.0f / 460.0f, 10);
  d = sel.update(f, 35);
  CHECK_FALSE(d.is_keyframe);
  // ... and with too few 2D-with-depth: keyframe for the depth rule.
  ums::AllocScope scope;
  d = sel.update(f, 20);
  if (ums::alloc_counter_available()) CHECK(scope.allocations() == 0);
  CHECK(d.reasons == ums::kKeyframeFewDepthFeatures);
}

TEST_CASE("keyframe: too few features shared with the last keyframe makes a keyframe") {
  ums::KeyframeSelector sel(ums::KeyframeOptions{});
  ums::FrameFeatures f;
  make_frame(&f, 0, 100, 0.0f, 100);
  sel.update(f, 0);
  make_frame(&f, 50'000'000, 100, 0.0f, 100);
  for (auto& o : f.features) o.id += 90;  // only ids 90..99 are shared
  const auto d = sel.update(f, 0);
  CHECK(d.shared_features == 10);
  CHECK((d.reasons & ums::kKeyframeFewShared) != 0);
}

TEST_CASE("KeyframeOptions::validate rejects a non-positive interval") {
  ums::KeyframeOptions o;
  o.max_interval_s = 0.0;
  CHECK_THROWS_AS(o.validate(), std::invalid_argument);
}
