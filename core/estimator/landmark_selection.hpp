#pragma once
// Which landmarks enter a solve (paper Sec. III-C: the best 100-300 features): depth known, not
// an outlier, at least two rays, of an allowed class; 3D first, each class best first (more
// observations, then longer track); when 2D classes are allowed they get a share of the budget
// (the united features), and 3D fill what 2D cannot.

#include <cstdint>

namespace ums {

class LandmarkMap;
struct Landmark;

// Classes as bits of LandmarkGroup.
enum GroupMask : std::uint8_t { k3DGroup = 1, k2DLeftGroup = 2, k2DRightGroup = 4, kAllGroups = 7 };

struct SelectionPolicy {
  int budget = 100;       // landmarks per solve
  double share_2d = 0.3;  // share of the budget offered to 2D landmarks
  double spread_cell_tan = 0.0;  // > 0: every viewing-direction cell of this size (tangent plane
                                 // of the camera, px / focal px) gives its best landmark before any
                                 // cell gives its second; 0: best first, wherever they are
};

bool is_candidate(const Landmark& l, std::uint8_t groups);
int count_candidates(const LandmarkMap& map, std::uint8_t groups);
// Writes the chosen pool indices to chosen[0, returned count); chosen has room for the map's capacity.
int select_landmarks(const LandmarkMap& map, std::uint8_t groups, const SelectionPolicy& policy, int* chosen);

}  // namespace ums
