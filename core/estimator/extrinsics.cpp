#include "core/estimator/extrinsics.hpp"

#include "core/estimator/state_blocks.hpp"

namespace ums {

void Extrinsics::set(const Eigen::Isometry3d& T_b_c0, const Eigen::Isometry3d& T_b_c1) {
  T_b_c_[0] = T_b_c0;
  T_b_c_[1] = T_b_c1;
  calibration_[0] = T_b_c0;
  calibration_[1] = T_b_c1;
  for (int c = 0; c < 2; ++c) pose_from_iso(T_b_c_[c], block_[c]);
}

void Extrinsics::sync() {
  if (!floating_) return;
  for (int c = 0; c < 2; ++c) T_b_c_[c] = iso_from_pose(block_[c]);
}

}  // namespace ums
