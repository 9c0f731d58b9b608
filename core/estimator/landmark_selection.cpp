#include "core/estimator/landmark_selection.hpp"

#include <algorithm>
#include <cmath>

#include "core/estimator/landmark_map.hpp"
#include "core/estimator/visual_edges.hpp"

namespace ums {

bool is_candidate(const Landmark& l, std::uint8_t groups) {
  if (!l.has_depth || l.outlier) return false;
  const std::uint8_t bit = static_cast<std::uint8_t>(1u << static_cast<int>(l.group()));
  if ((groups & bit) == 0) return false;
  return count_rays(l) >= 2;
}

int count_candidates(const LandmarkMap& map, std::uint8_t groups) {
  int n = 0;
  for (int k = 0; k < map.size(); ++k) n += is_candidate(map[k], groups) ? 1 : 0;
  return n;
}

int select_landmarks(const LandmarkMap& map, std::uint8_t groups, const SelectionPolicy& policy, int* chosen) {
  int nc = 0;
  for (int k = 0; k < map.size(); ++k)
    if (is_candidate(map[k], groups)) chosen[nc++] = map.pool_index(k);
  auto score = [&map](int idx) {
    const Landmark& l = map.at_pool(idx);
    return 1000 * l.n_obs + static_cast<int>(std::min<std::uint32_t>(l.track_length, 999));
  };
  int* begin = chosen;
  int* mid = std::partition(begin, begin + nc, [&map](int idx) { return map.at_pool(idx).stereo; });
  const int n3 = static_cast<int>(mid - begin), n2 = nc - n3;
  const int share_2d = static_cast<int>(std::lround(policy.share_2d * policy.budget));
  const int take2 = std::min(n2, std::max(share_2d, policy.budget - n3));
  const int take3 = std::min(n3, policy.budget - take2);
  auto better = [&](int a, int b) { return score(a) > score(b); };
  std::partial_sort(begin, begin + take3, mid, better);
  std::partial_sort(mid, mid + take2, begin + nc, better);
  std::copy(mid, mid + take2, begin + take3);  // chosen: [0, take3 + take2)
  return take3 + take2;
}

}  // namespace ums
