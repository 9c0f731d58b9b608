#pragma once
// The visual residual of paper eq. (3)/(5): the unit bearing at which a landmark should be seen
// minus the measured unit bearing, expressed in the 2-D tangent plane of the measurement (two
// rows, radians), whitened by focal_px / sigma_px and weighted by the paper's beta (beta1 for
// left-camera observations, beta2 for right-camera ones). Working on bearings instead of the
// z = 1 plane keeps the residual valid for wide-angle lenses and points near the image border.
//
// The landmark is an inverse distance rho (1/m) along the measured unit bearing b_h of its host
// observation (host frame h, host camera):
//   P_ch = b_h / rho,  P_bh = T_b_ch P_ch,  P_w = T_w_bh P_bh,  P_bt = T_w_bt^-1 P_w,
//   P_ct = T_b_ct^-1 P_bt,  r = w * B^T (P_ct / |P_ct| - b_t),  B = basis of the plane normal to b_t.
// Parameter blocks, in this order:
//   kTwoFrames, same camera:       pose_h, pose_t, T_b_c (host = target camera), rho
//   kTwoFrames, different cameras: pose_h, pose_t, T_b_ch, T_b_ct, rho
//   kSameFrame (stereo pair):      T_b_ch, T_b_ct, rho  (the body pose cancels)
// Poses and extrinsics are 7-double pose blocks (docs/conventions.md); Jacobians are analytic.
//
// With a time offset (set_time_offset, estimate_td): one more block after rho, the camera-IMU
// offset td (1 double, s). A frame is stamped with td_applied (the offset its time was corrected
// by, its own: the pipeline restamps new frames as td is refined); the image was in fact taken
// td - td_applied later, so each measured bearing is moved back along its image velocity v (1/s):
// b(td) = b - (td - td_applied) v, host and target each with their frame's td_applied
// (VINS-Fusion's model; first order in what is left of the offset, well under a ms once settled).

#include <cstdint>

#include <Eigen/Core>

#include "core/estimator/relative_pose_cache.hpp"
#include "solver/double_pair.hpp"
#include "solver/residual.hpp"

namespace ums {

class BearingResidual final : public solver::ResidualFunction {
 public:
  enum class Kind : unsigned char { kTwoFrames, kSameFrame };

  BearingResidual() = default;
  // b_host, b_target: measured unit bearings in the host and target cameras. weight: whitening
  // (focal_px / sigma_px times beta), 1/rad.
  void set(Kind kind, bool same_camera, const Eigen::Vector3d& b_host, const Eigen::Vector3d& b_target,
           double weight);
  // Optional, after set() (which unbinds): a kTwoFrames residual whose pose blocks are the cache's
  // frame slots and extrinsics takes the shared products from it (a kSameFrame one its
  // extrinsics' pair, the slots unused). Evaluation at other blocks, and
  // Jacobians with respect to the extrinsics, use the residual's own products: results agree to
  // rounding either way. The cache must be invalidated when blocks move (a solver with the cache as
  // its evaluation callback does it); it is written during evaluate(): one solve at a time.
  void bind(RelativePoseCache* cache, int host_slot, int host_cam, int target_slot, int target_cam);
  // Optional, after set(): the td block is appended. v_host, v_target: the measured bearings'
  // velocities (1/s, in their cameras); td_applied_*_s: the offset each frame's stamp carries.
  void set_time_offset(const Eigen::Vector3d& v_host, const Eigen::Vector3d& v_target, double td_applied_host_s,
                       double td_applied_target_s);

  int num_residuals() const override { return 2; }
  // The point is the landmark in the world, P_w (BearingLift gives d P_w / d (host pose, rho)):
  // with jacobians[0].point, d r / d P_w (2 x 3) is written there instead of d r / d pose_h.
  bool supports_point_jacobian() const override { return true; }
  int num_blocks() const { return num_blocks_; }
  bool evaluate(const double* const* parameters, double* residuals,
                const solver::JacobianView* jacobians) const override;

  // Angle-like error (rad, unwhitened) at the given parameters; false behind the camera.
  bool error_rad(const double* const* parameters, double* error) const;

  // v / |v| with one division, as set() normalizes the bearings (v unchanged when zero).
  static Eigen::Vector3d unit(const Eigen::Vector3d& v);

 private:
  bool evaluate_cached(const double* const* parameters, double* residuals,
                       const solver::JacobianView* jacobians) const;
  bool evaluate_uncached(const double* const* parameters, double* residuals,
                         const solver::JacobianView* jacobians) const;
  bool evaluate_same_frame_cached(const double* const* parameters, double* residuals,
                                  const solver::JacobianView* jacobians) const;
  bool project(const Eigen::Vector3d& P_ct, const Eigen::Vector3d& b_target, double* residuals,
               Eigen::Matrix<double, 2, 3>* D) const;
  // project() with d r / d P_ct as its three columns, each a packet of two doubles (the same
  // doubles): the cached evaluation's form.
  bool project_packets(const Eigen::Vector3d& P_ct, const Eigen::Vector3d& b_target, double* residuals,
                       solver::Pair* D) const;
  int rho_block() const { return num_blocks_ - 1 - static_cast<int>(has_td_); }
  void count_blocks();  // num_blocks_ from the kind, the cameras and the td block
  // The measured bearings moved by the offset at these parameters (b_host_, b_target_ without one).
  void shifted_bearings(const double* const* parameters, Eigen::Vector3d* b_host, Eigen::Vector3d* b_target) const;
  // d r / d td from d r / d P_ct and the map of host-camera vectors into the target camera.
  void write_td_jacobian(const Eigen::Matrix<double, 2, 3>& D, const Eigen::Matrix3d& R_ct_ch, double inv_rho,
                         const solver::JacobianView* jacobians) const;

  RelativePoseCache* cache_ = nullptr;
  std::int8_t host_slot_ = 0, host_cam_ = 0, target_slot_ = 0, target_cam_ = 0;
  Kind kind_ = Kind::kTwoFrames;
  bool same_camera_ = true;
  Eigen::Vector3d b_host_ = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d b_target_ = Eigen::Vector3d::UnitZ();
  // B^T: the rows are the tangent plane's axes (stored by columns: each column of B^T, a pair of
  // doubles, is one packet of the cached evaluation).
  Eigen::Matrix<double, 2, 3> tangent_t_ = Eigen::Matrix<double, 2, 3>::Zero();
  double weight_ = 1.0;
  bool has_td_ = false;
  std::int8_t num_blocks_ = 4;  // evaluated per call: set by set() and set_time_offset()
  double td_applied_host_s_ = 0.0, td_applied_target_s_ = 0.0;
  Eigen::Vector3d v_host_ = Eigen::Vector3d::Zero();    // 1/s
  Eigen::Vector3d v_target_ = Eigen::Vector3d::Zero();  // 1/s
};

}  // namespace ums
