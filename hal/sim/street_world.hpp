#pragma once
// A street-sized world for the car routes (car_route.hpp), in the renderer's World form (room +
// axis-aligned boxes, renderer.hpp):
//  - road: the floor at z = 0, textured;
//  - facades: the room's walls, half_width_m beyond the path's bounding box, and "city blocks":
//    boxes filling every part of the room farther than half_width_m from the path (the inside of
//    a corner or a loop), so the camera sees facades 5-8 m away, not a far empty wall. The blocks
//    come from a grid of cell_m cells, merged into row runs and then into rectangles;
//  - sky: a textureless ceiling at sky_height_m (no features overhead).
// Facade and road textures are the procedural material (renderer.hpp) with a 4 m tile: they repeat
// every 4 m along a street. At 6 m range that repeat is ~290 px apart in the image, beyond the
// stereo search, and 20 frames of driving at 30 Hz: harmless for VIO, but place recognition
// would see the same wall twice.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hal/sim/renderer.hpp"

namespace ums::sim {

struct StreetOptions {
  double half_width_m = 6.0;     // facades at least this far from the path (horizontally), m
  double block_height_m = 15.0;  // city blocks' height, m
  double sky_height_m = 40.0;    // textureless ceiling, m above the road
  double cell_m = 1.0;           // grid of the blocks' footprint, m
  int texture_size = 1024;       // texels per side of a 4 m tile (power of two; tests: 256)
  std::uint32_t seed = 1;
  bool validate(std::string* error) const;
};

// The street around path_w (camera or body positions; the road is z = 0). Throws on invalid
// options or an empty path.
World make_street_world(const std::vector<Eigen::Vector3d>& path_w, const StreetOptions& options);

}  // namespace ums::sim
