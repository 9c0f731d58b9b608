#include "core/estimator/landmark_selection.hpp"

#include <algorithm>
#include <cmath>

#include "core/common/capacity.hpp"
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

namespace {

constexpr int kDirectionCells = 64;  // per axis: any field of view within 64 cells

// Viewing-direction cell of a landmark's newest observation: squares of cell_tan on the tangent
// plane z = 1 of that camera (divisions only: the same cell on every machine), so a selection can
// cover the view instead of its best-tracked part.
int direction_cell(const Landmark& l, double cell_tan) {
  const LandmarkObservation& o = l.obs[l.n_obs - 1];
  const Eigen::Vector3f& b = o.has_left ? o.bearing_left : o.bearing_right;
  const double z = std::max(1e-3, static_cast<double>(b.z()));
  const double half = kDirectionCells / 2;
  const double u = std::clamp(std::floor(static_cast<double>(b.x()) / z / cell_tan), -half, half - 1.0) + half;
  const double v = std::clamp(std::floor(static_cast<double>(b.y()) / z / cell_tan), -half, half - 1.0) + half;
  return static_cast<int>(u) * kDirectionCells + static_cast<int>(v);
}

// Orders [begin, end) so that its first `take` are chosen: best score first, or, with a cell
// size, each direction cell's best before any cell's second best (score, then pool index,
// breaks ties: the same set on every machine).
void order_group(const LandmarkMap& map, const SelectionPolicy& policy, int* begin, int* end, int take) {
  auto score = [&map](int idx) {
    const Landmark& l = map.at_pool(idx);
    return 1000 * l.n_obs + static_cast<int>(std::min<std::uint32_t>(l.track_length, 999));
  };
  const int n = static_cast<int>(end - begin);
  if (!(policy.spread_cell_tan > 0.0) || take >= n) {
    std::partial_sort(begin, begin + take, end, [&](int a, int b) { return score(a) > score(b); });
    return;
  }
  std::sort(begin, end, [&](int a, int b) { return score(a) != score(b) ? score(a) > score(b) : a < b; });
  // Rank within its cell, in score order: the k-th best of a cell gets rank k.
  static_assert(capacity::kMaxLandmarks <= 1024, "rank table on the stack");
  std::uint16_t in_cell[kDirectionCells * kDirectionCells] = {};
  // Pack (rank in its cell, position in score order) and sort: rank first, then score.
  int key[capacity::kMaxLandmarks];
  for (int i = 0; i < n; ++i) {
    const int rank = in_cell[direction_cell(map.at_pool(begin[i]), policy.spread_cell_tan)]++;
    key[i] = rank * static_cast<int>(capacity::kMaxLandmarks) + i;
  }
  std::sort(key, key + n);
  int sorted[capacity::kMaxLandmarks];
  for (int i = 0; i < n; ++i) sorted[i] = begin[key[i] % static_cast<int>(capacity::kMaxLandmarks)];
  std::copy(sorted, sorted + n, begin);
}

}  // namespace

int select_landmarks(const LandmarkMap& map, std::uint8_t groups, const SelectionPolicy& policy, int* chosen) {
  int nc = 0;
  for (int k = 0; k < map.size(); ++k)
    if (is_candidate(map[k], groups)) chosen[nc++] = map.pool_index(k);
  int* begin = chosen;
  int* mid = std::partition(begin, begin + nc, [&map](int idx) { return map.at_pool(idx).stereo; });
  const int n3 = static_cast<int>(mid - begin), n2 = nc - n3;
  const int share_2d = static_cast<int>(std::lround(policy.share_2d * policy.budget));
  const int take2 = std::min(n2, std::max(share_2d, policy.budget - n3));
  const int take3 = std::min(n3, policy.budget - take2);
  order_group(map, policy, begin, mid, take3);
  order_group(map, policy, mid, begin + nc, take2);
  std::copy(mid, mid + take2, begin + take3);  // chosen: [0, take3 + take2)
  return take3 + take2;
}

}  // namespace ums
