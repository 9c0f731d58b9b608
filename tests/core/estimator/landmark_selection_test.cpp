#include "core/estimator/landmark_selection.hpp"

#include <catch2/catch.hpp>
#include <memory>
#include <set>
#include <vector>

#include "core/common/capacity.hpp"
#include "core/estimator/landmark_map.hpp"
#include "tests/core/estimator/stereo_scene.hpp"

namespace {

// Stereo frames 0.1 m apart along x, cameras looking along z, a 0.11 m baseline; landmarks at
// 4 m. 100 "clustered" points crowd one corner of the view and are seen from the first frame;
// 20 "spread" points cover the view on a 5 x 4 grid and are seen from the second frame on, so
// every clustered landmark outranks every spread one (more observations).
struct Scene {
  ums::test::StereoScene stereo;
  ums::LandmarkMap map{ums::LandmarkMapOptions()};
  std::vector<Eigen::Vector3d> points;  // id i + 1 is points[i]

  Scene() {
    for (int i = 0; i < kClustered; ++i) {
      points.emplace_back(4.0 * (-0.45 + 0.004 * (i % 10)), 4.0 * (-0.30 + 0.004 * (i / 10)), 4.0);
    }
    for (int i = 0; i < kSpread; ++i) {
      points.emplace_back(4.0 * (-0.5 + 0.25 * (i % 5)), 4.0 * (-0.3 + 0.2 * (i / 5)), 4.0);
    }
    REQUIRE(stereo.add_frame(0.0, points.data(), kClustered, true, &map) >= 0);
    REQUIRE(stereo.add_frame(0.1, points.data(), kClustered + kSpread, true, &map) >= 0);
    REQUIRE(stereo.add_frame(0.2, points.data(), kClustered + kSpread, true, &map) >= 0);
    map.triangulate_all(stereo.window, -1);
  }
  // How many of the chosen landmarks are spread ones.
  int spread_chosen(const ums::SelectionPolicy& policy) const {
    std::vector<int> chosen(ums::capacity::kMaxLandmarks);
    const int n = ums::select_landmarks(map, ums::kAllGroups, policy, chosen.data());
    REQUIRE(n == policy.budget);
    std::set<int> spread_pool;
    for (int i = 0; i < kSpread; ++i) spread_pool.insert(map.find(static_cast<std::uint32_t>(kClustered + i + 1)));
    int k = 0;
    for (int i = 0; i < n; ++i) k += spread_pool.count(chosen[static_cast<std::size_t>(i)]) ? 1 : 0;
    return k;
  }

  static constexpr int kClustered = 100;
  static constexpr int kSpread = 20;
};

}  // namespace

TEST_CASE("select_landmarks: best first takes the crowded corner, a cell size covers the view", "[estimator][selection]") {
  Scene s;
  REQUIRE(ums::count_candidates(s.map, ums::kAllGroups) == Scene::kClustered + Scene::kSpread);
  ums::SelectionPolicy policy;
  policy.budget = 30;
  // Best first: the 30 clustered landmarks with three observations, none of the spread ones.
  CHECK(s.spread_chosen(policy) == 0);
  // 80 px cells at a 460 px focal length: each spread landmark has a cell of its own (0.25 x 0.2
  // apart on the tangent plane, cells 0.17), the cluster fills one or two: every spread landmark
  // is some cell's best, so all 20 are chosen before any cell's second.
  policy.spread_cell_tan = 80.0 / 460.0;
  CHECK(s.spread_chosen(policy) == Scene::kSpread);
}

TEST_CASE("select_landmarks: a budget larger than the candidates takes them all, spread or not", "[estimator][selection]") {
  Scene s;
  ums::SelectionPolicy policy;
  policy.budget = Scene::kClustered + Scene::kSpread;
  policy.spread_cell_tan = 80.0 / 460.0;
  CHECK(s.spread_chosen(policy) == Scene::kSpread);
}
