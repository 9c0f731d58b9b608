#pragma once
// The photo style's world: a larger and more varied room than make_world's (renderer.hpp), so
// that much of the scene is far away, as in a machine hall where a 0.11 m stereo baseline gives
// little depth:
//  - each wall at its own seeded distance of 3-12 m beyond the path's bounding box, the floor
//    0.5-1.5 m below the lowest path point, the ceiling 4-8 m above the highest;
//  - boxes of many sizes (0.3-3 m footprint, 0.3-4 m tall) on the floor and floor-to-ceiling
//    pillars (0.3-0.8 m square), all kept box_clearance_m clear of the path;
//  - photo materials (photo_texture.hpp) at 96-192 texel/m (5-10 mm per texel), one per face
//    and a pool shared by the boxes; a textureless material for the `textureless` scenario;
//  - uneven lighting (lighting.hpp) and a seeded albedo per face orientation.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hal/sim/photo_texture.hpp"
#include "hal/sim/renderer.hpp"

namespace ums::sim {

struct PhotoWorldOptions {
  double wall_distance_min_m = 3.0;   // m beyond the path's bounding box, drawn per wall
  double wall_distance_max_m = 12.0;  // m
  double floor_below_min_m = 0.8;     // m below the lowest path point
  double floor_below_max_m = 1.6;     // m
  double ceiling_above_min_m = 4.0;   // m above the highest path point
  double ceiling_above_max_m = 8.0;   // m
  int boxes = 12;                     // boxes on the floor
  int pillars = 6;                    // floor-to-ceiling pillars
  double box_distance_min_m = 2.0;    // box centre from a random path point, m (range)
  double box_distance_max_m = 9.0;    // m
  double box_clearance_m = 0.8;       // minimum distance of any box from the path, m
  int box_materials = 6;              // photo materials shared by boxes and pillars
  bool textureless_walls = false;     // `textureless` scenario: walls and ceiling textureless
  int texture_size = 1024;            // texels per side of a material (power of two; tests: 256)
  int lights = 5;                     // point lights (lighting.hpp)
  std::uint32_t seed = 1;
  bool validate(std::string* error) const;
};

// Throws std::runtime_error on invalid options or an empty path.
World make_photo_world(const std::vector<Eigen::Vector3d>& path_w, const PhotoWorldOptions& options,
                       const PhotoSource& source);

}  // namespace ums::sim
