#pragma once
// Multi-view geometry of the estimator, on unit bearings: triangulation of a landmark from any
// set of rays (stereo pair, several frames, or both) and PnP of one frame against landmarks
// with known positions, made robust by RANSAC (paper Sec. III-B: robust PnP for the visual
// initialization and frame tracking). Allocation-free.

#include <cstdint>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ums {

// A ray in the world: origin (camera centre) and unit direction.
struct Ray {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
};

struct TriangulationResult {
  bool ok = false;
  Eigen::Vector3d p_w = Eigen::Vector3d::Zero();
  double max_angle_rad = 0.0;   // largest angle between the first ray and another one
};

// Point closest to all rays in the least-squares sense (sum of squared distances to the lines).
// ok = false when fewer than two rays, the largest ray angle is below min_angle_rad or the point
// lies behind a ray's origin.
TriangulationResult triangulate(const Ray* rays, int n, double min_angle_rad);

// One correspondence: a world point and the unit bearing of its observation in camera `cam`.
struct PnpMatch {
  Eigen::Vector3d p_w = Eigen::Vector3d::Zero();
  Eigen::Vector3d bearing = Eigen::Vector3d::UnitZ();
  std::uint8_t cam = 0;
};

struct PnpOptions {
  int ransac_iterations = 40;      // count
  int sample_size = 4;             // points per hypothesis (Gauss-Newton from the prior pose)
  double inlier_rad = 0.0065;      // rad, ~3 px at 460 px focal length
  int gn_iterations = 8;           // per hypothesis / refinement
  int min_inliers = 12;            // count
  std::uint32_t seed = 12345;
};

struct PnpResult {
  bool ok = false;
  int inliers = 0;
  double rms_rad = 0.0;            // over inliers, after refinement
};

// Body pose of one frame from matches, starting from the prior T_w_b (e.g. IMU or constant
// velocity prediction): RANSAC over small samples, each fitted by Gauss-Newton from the prior,
// then a refinement on all inliers. T_b_c[cam] are the camera extrinsics. inlier_mask (n bytes)
// receives 1 for inliers. matches[] are read only.
PnpResult solve_pnp(const PnpMatch* matches, int n, const Eigen::Isometry3d* T_b_c,
                    const PnpOptions& options, Eigen::Isometry3d* T_w_b, std::uint8_t* inlier_mask);

}  // namespace ums
