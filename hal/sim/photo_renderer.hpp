#pragma once
// The photo style's stereo renderer: the world of renderer.hpp (room, boxes, mip-mapped
// materials, same ray casting and texture filtering as StereoRenderer) seen through a camera
// with the effects the procedural renderer leaves out:
//  - motion blur: a frame is the mean of n sub-exposures at body poses spread over the
//    exposure time (exposure.hpp picks n from the motion);
//  - uneven light: the texel value times World::lighting's irradiance at the hit point (and
//    the face shade), so one surface is brighter near a light;
//  - vignetting: a per-pixel gain (vignetting.hpp), different for left and right;
//  - sensor noise with a signal-dependent (shot) part: sigma^2 = read^2 + shot_dn * value.
// Boxes are culled per 16x16-pixel tile against a cone around the tile's rays, so a larger box
// count costs little. Noise comes from a per-pixel hash (deterministic for any thread count).
// Start-up allocates; render() allocates nothing.

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/calibration.hpp"
#include "hal/sim/camera_rays.hpp"
#include "hal/sim/renderer.hpp"
#include "hal/sim/vignetting.hpp"

namespace ums::sim {

struct PhotoLensOptions {
  // Left a little stronger and decentred one way, right weaker and decentred the other.
  VignettingOptions vignetting[2] = {{0.65, Eigen::Vector2d(0.012, -0.008)}, {0.70, Eigen::Vector2d(-0.010, 0.006)}};
  double shot_noise_dn = 0.03;  // DN: shot-noise variance per DN of signal
  bool validate(std::string* error) const;
};

inline constexpr int kMaxSubExposures = 8;  // poses averaged into one frame
inline constexpr int kMaxPhotoBoxes = 64;   // boxes the per-tile culling mask holds

class PhotoRenderer {
 public:
  // Precomputes rays, vignetting and tile cones of both cameras. Throws std::runtime_error on an
  // invalid calibration or options, or more than kMaxPhotoBoxes boxes.
  PhotoRenderer(const World& world, const RigCalibration& rig, const PhotoLensOptions& lens);

  // Renders camera `cam` (0 or 1) as the mean of the sub-exposures at body poses T_w_b[0 ..
  // n_poses) (1 <= n_poses <= kMaxSubExposures) into `out` (width*height, stride = width).
  void render(int cam, const Eigen::Isometry3d* T_w_b, int n_poses, const RenderOptions& options,
              std::uint64_t noise_key, std::uint8_t* out) const;

  // Both cameras, one thread each (std::thread per call).
  void render_stereo(const Eigen::Isometry3d* T_w_b, int n_poses, const RenderOptions& options,
                     std::uint64_t noise_key, std::uint8_t* left, std::uint8_t* right) const;

  const std::vector<float>& vignetting(int cam) const { return vignetting_[cam]; }
  int width(int cam) const { return rays_[cam].width; }
  int height(int cam) const { return rays_[cam].height; }

 private:
  struct TileCone {
    Eigen::Vector3f axis_c;   // unit, camera frame
    float half_angle_rad;     // largest angle of a tile ray from the axis
  };
  struct SubPose {
    Eigen::Matrix3f R_w_c;
    Eigen::Vector3f p_w_c;
  };
  static constexpr int kTile = 16;  // px

  std::uint64_t visible_boxes(const TileCone& cone, const SubPose* poses, int n_poses) const;
  float radiance(int cam, std::size_t pixel, const SubPose& pose, std::uint64_t box_mask) const;

  const World& world_;
  RigCalibration rig_;
  PhotoLensOptions lens_;
  CameraRays rays_[2];
  std::vector<float> vignetting_[2];
  std::vector<TileCone> tiles_[2];          // row-major tiles of kTile x kTile pixels
  std::vector<Eigen::Vector4f> box_sphere_; // bounding sphere per box: centre (m), radius (m)
};

}  // namespace ums::sim
