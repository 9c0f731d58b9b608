#pragma once
// The camera-to-body extrinsics T_b_c0, T_b_c1: one copy for every user. The solver moves the
// pose blocks when `estimate_extrinsic` is on; sync() then refreshes the isometries that
// triangulation, rehosting, PnP and the image-flow test read. Before, a second copy set once at
// start-up kept those users on the calibration while the solver moved the blocks.

#include <Eigen/Geometry>

#include "core/common/state_layout.hpp"

namespace ums {

class Extrinsics {
 public:
  // T_b_c: camera c -> IMU body.
  void set(const Eigen::Isometry3d& T_b_c0, const Eigen::Isometry3d& T_b_c1);
  const Eigen::Isometry3d& T_b_c(int cam) const { return T_b_c_[cam]; }
  // As set(): the calibration the floating extrinsics are held to.
  const Eigen::Isometry3d& calibration(int cam) const { return calibration_[cam]; }
  const Eigen::Isometry3d* T_b_c_array() const { return T_b_c_; }
  double* block(int cam) { return block_[cam]; }
  const double* block(int cam) const { return block_[cam]; }
  // Floating: the solver may move the blocks (estimate_extrinsic). Fixed extrinsics keep the
  // calibration's isometries bit for bit.
  void set_floating(bool floating) { floating_ = floating; }
  bool floating() const { return floating_; }
  // After a solve (or a restore) that may have moved the blocks; nothing when fixed.
  void sync();

 private:
  double block_[2][state::kPoseSize] = {};
  bool floating_ = false;
  Eigen::Isometry3d T_b_c_[2] = {Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity()};
  Eigen::Isometry3d calibration_[2] = {Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity()};
};

}  // namespace ums
