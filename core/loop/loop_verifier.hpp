#pragma once
// Geometric verification of a place-recognition candidate: the query keyframe's 3D features are
// matched to the candidate's by descriptor (mutual nearest neighbours under a Hamming bound),
// the relative pose is found by 3-point RANSAC on the two stereo point sets (Umeyama, no prior
// needed, so it also works after the odometry was lost) scored by reprojection in both left
// cameras, and refined by PnP on the candidate's points and the query's bearings. The gates that
// follow (inliers, gravity, drift budget) are the loop closer's. Scratch allocated once.

#include <cstdint>
#include <memory>

#include <Eigen/Geometry>

#include "core/loop/keyframe_database.hpp"

namespace ums::loop {

struct LoopVerifierOptions {
  int max_hamming = 64;            // bits of 256: a descriptor match (BRIEF on the same corner: ~12-40)
  int ransac_iterations = 200;     // 3-point hypotheses
  double inlier_rad = 0.006;       // rad, ~3 px at a 460 px focal length, in both cameras
  int min_matches = 20;            // descriptor matches before RANSAC is tried
  std::uint32_t seed = 7;          // RANSAC's sampling (deterministic)
};

struct LoopGeometry {
  int matches = 0;                 // mutual descriptor matches
  int inliers = 0;                 // after the PnP refinement
  double rms_rad = 0.0;            // over the inliers
  // 1-sigma of the relative pose from the last fit's information (J^T J over the inliers' bearing
  // errors in both keyframes, scaled by their residual variance): largest axis, m and rad.
  double sigma_p_m = 0.0;
  double sigma_rot_rad = 0.0;
  Eigen::Isometry3d T_c_q = Eigen::Isometry3d::Identity();  // query body in the candidate's body frame
};

class LoopVerifier {
 public:
  // T_b_c0: the left camera in the body frame (bearings are cam0's).
  LoopVerifier(const LoopVerifierOptions& options, const Eigen::Isometry3d& T_b_c0);
  LoopVerifier(const LoopVerifier&) = delete;
  LoopVerifier& operator=(const LoopVerifier&) = delete;

  // Fills *out; false when too few matches or no hypothesis with 4+ inliers (out->matches and
  // out->inliers still tell how far it got).
  bool verify(const KeyframeRecord& query, const KeyframeRecord& candidate, LoopGeometry* out);
  // The last successful verify()'s inliers as feature indices of the query and the candidate.
  int inlier_pairs(std::uint16_t* query_index, std::uint16_t* candidate_index) const;

 private:
  int match(const KeyframeRecord& query, const KeyframeRecord& candidate);
  int count_inliers(const KeyframeRecord& q, const KeyframeRecord& c, const Eigen::Isometry3d& T_c_q,
                    std::uint8_t* mask, double bound_rad) const;
  bool ransac(const KeyframeRecord& q, const KeyframeRecord& c, Eigen::Isometry3d* T_c_q);
  bool refine(const KeyframeRecord& q, const KeyframeRecord& c, LoopGeometry* out);
  // Gauss-Newton on the inliers' bearing errors in both keyframes (each keyframe's points seen
  // from the other): both stereo depths count, so neither keyframe's depth errors set the pose.
  void refine_both_ways(const KeyframeRecord& q, const KeyframeRecord& c, Eigen::Isometry3d* T_c_q) const;
  Eigen::Matrix<double, 6, 1> both_ways_residual_sum(const KeyframeRecord& q, const KeyframeRecord& c,
                                                    const Eigen::Isometry3d& T_c_q, Eigen::Matrix<double, 6, 6>* H,
                                                    double* squared_sum = nullptr, int* rows = nullptr) const;
  // sigma_p_m and sigma_rot_rad of *out at out->T_c_q over the current inliers.
  void uncertainty(const KeyframeRecord& q, const KeyframeRecord& c, LoopGeometry* out) const;

  LoopVerifierOptions options_;
  Eigen::Isometry3d T_b_c0_;
  Eigen::Isometry3d T_c0_b_;
  int n_ = 0;
  std::unique_ptr<std::uint16_t[]> qi_, ci_;     // matched feature indices
  std::unique_ptr<std::int16_t[]> best_of_c_;    // per candidate feature: its best query feature
  std::unique_ptr<std::uint8_t[]> mask_;
  std::unique_ptr<std::uint8_t[]> best_mask_;
};

}  // namespace ums::loop
