#pragma once
// Uneven illumination for the photo style: the irradiance at a surface point depends on where
// the point is, so one material is brighter in some places than in others (the procedural
// style only has a constant shade per face orientation).
//
// A few point lights with a softened inverse-square falloff and Lambert's cosine, plus ambient:
//   E(x, n) = ambient + sum_k I_k max(0, n . l_k) / (1 + |L_k - x|^2 / r_k^2),  l_k = (L_k - x) / |L_k - x|
// No shadows. make_lighting scales the intensities so that the mean of E over the room's
// surfaces is mean_irradiance (the exposure the images are set for).

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace ums::sim {

struct PointLight {
  Eigen::Vector3f p_w = Eigen::Vector3f::Zero();  // m, world
  float intensity = 0.0f;                         // irradiance factor at distance 0, unitless
  float radius_m = 3.0f;                          // m, distance where the falloff halves it
};

struct Lighting {
  float ambient = 1.0f;             // unitless
  std::vector<PointLight> lights;   // empty: uniform light (E = ambient)

  // Irradiance factor at x_w on a surface with unit normal n_w (pointing into the room).
  float irradiance(const Eigen::Vector3f& x_w, const Eigen::Vector3f& n_w) const;
};

struct LightingOptions {
  int lights = 5;                   // point lights under the ceiling and on the walls
  float ambient_share = 0.3f;       // ambient / mean irradiance
  float mean_irradiance = 1.25f;    // mean of E over the room's surfaces (images: mean ~110 DN)
  std::uint32_t seed = 1;
};

// Lights at seeded positions inside the room box [room_lo, room_hi] (most near the ceiling).
Lighting make_lighting(const Eigen::Vector3f& room_lo, const Eigen::Vector3f& room_hi, const LightingOptions& options);

}  // namespace ums::sim
