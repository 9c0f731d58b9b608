#pragma once
// The simulated world and its stereo renderer.
//
// World: an axis-aligned room sized from the trajectory's bounding box plus a margin (walls
// 1.5-4 m from the path), a few textured axis-aligned boxes kept clear of the path, and one
// material per surface. Materials are procedural, deterministic (seeded hash) textures with
// piecewise-constant value noise in octaves of 4..128 texels (1.6 cm .. 0.5 m at 256 texel/m), so
// cell junctions give Shi-Tomasi corners at every pyramid level; the `textureless` material is
// flat grey with faint low-frequency shading. Textures are mip-mapped (2x2 box filter).
//
// Renderer: one ray per pixel from a start-up table of unit bearings (core/camera unproject, so
// the image follows the configured pinhole radtan/equidistant model exactly), intersected with
// the room and boxes; bilinear texture sampling at the mip level matching the pixel footprint,
// which is the anti-aliasing (pre-filtered, no shimmering on far walls); exposure gain; additive
// Gaussian-like sensor noise from a per-row hash stream (deterministic for any thread count).
// Start-up allocates; render() allocates nothing.

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/camera/camera.hpp"
#include "core/common/calibration.hpp"
#include "hal/sim/lighting.hpp"

namespace ums::sim {

struct Texture {
  int size = 0;                                 // texels per side at level 0 (power of two)
  float texels_per_m = 256.0f;                  // texel/m
  std::vector<std::vector<std::uint8_t>> mips;  // level l: (size >> l)^2 texels

  // Builds the mip chain from mips[0].
  void build_mips();
  // Bilinear sample at (u, v) metres on the surface, at mip `level`; repeats.
  float sample(float u_m, float v_m, int level) const;
};

Texture make_textured_material(std::uint32_t seed, int size = 1024, float texels_per_m = 256.0f);
Texture make_textureless_material(std::uint32_t seed, int size = 256, float texels_per_m = 32.0f);

struct Box {
  Eigen::Vector3f lo = Eigen::Vector3f::Zero(), hi = Eigen::Vector3f::Zero();  // m, world
  int material = 0;
};

struct WorldOptions {
  double margin_xy_m = 2.5;       // wall distance beyond the path's bounding box, m
  double margin_down_m = 1.5;     // floor below the lowest path point, m
  double margin_up_m = 1.5;       // ceiling above the highest path point, m
  int boxes = 5;                  // textured boxes placed clear of the path
  double box_clearance_m = 0.8;   // minimum distance of a box from any path point, m
  bool textureless_walls = false; // `textureless` scenario: walls and ceiling textureless
  int texture_size = 1024;        // texels per side of a 4 m wall tile (power of two; tests: 256)
  std::uint32_t seed = 1;
  bool validate(std::string* error) const;
};

struct World {
  Eigen::Vector3f room_lo = Eigen::Vector3f::Zero(), room_hi = Eigen::Vector3f::Zero();  // m
  // Face order: -x, +x, -y, +y, -z (floor), +z (ceiling): index 2 * axis + (positive side).
  std::array<int, 6> face_material{};
  std::array<float, 6> face_shade{};  // Lambert-like constant factor per face orientation
  std::vector<Box> boxes;
  std::vector<Texture> materials;
  Lighting lighting;  // photo style only (photo_renderer.hpp); the procedural renderer ignores it
};

World make_world(const std::vector<Eigen::Vector3d>& path_w, const WorldOptions& options);

struct RenderOptions {
  double noise_sigma_dn = 2.0;   // additive sensor noise, std in grey levels (DN)
  double exposure_gain = 1.0;    // multiplies radiance (exposure change), unitless
  bool validate(std::string* error) const;
};

class StereoRenderer {
 public:
  // Precomputes the bearing tables of both cameras. Throws on an invalid calibration.
  StereoRenderer(const World& world, const RigCalibration& rig);

  // Renders camera `cam` (0 or 1) with the body pose T_w_b into `out` (width*height, stride =
  // width). `noise_key` seeds the noise stream (frame index, seed). Rows [row_begin, row_end).
  void render(int cam, const Eigen::Isometry3d& T_w_b, const RenderOptions& options, std::uint64_t noise_key,
              std::uint8_t* out, int row_begin = 0, int row_end = -1) const;

  // Both cameras, one thread each (std::thread per call; 2 cores here).
  void render_stereo(const Eigen::Isometry3d& T_w_b, const RenderOptions& options, std::uint64_t noise_key,
                     std::uint8_t* left, std::uint8_t* right) const;

  int width(int cam) const { return rig_.cam[cam].width; }
  int height(int cam) const { return rig_.cam[cam].height; }

 private:
  const World& world_;
  RigCalibration rig_;
  std::vector<Eigen::Vector3f> bearing_[2];  // unit ray per pixel, camera frame
  std::vector<float> footprint_[2];          // pixel solid-angle scale: m of footprint per m of range
};

}  // namespace ums::sim
