#pragma once
// The estimator's state in the frames a flight controller expects (MAV_FRAME_LOCAL_FRD pose,
// MAV_FRAME_BODY_FRD velocity and rates). The estimator's world w is gravity-aligned z-up with an
// arbitrary heading, its body b the IMU; the vehicle's body v is forward-right-down, mounted
// with v_b = R_b_v v_v (body_T_vehicle in the configuration). The local frame L is earth-fixed,
// z down, x along the vehicle's forward direction in the horizontal plane at the first pose
// converted (so a flight forward from the start reads +x, to the right +y, up -z):
//
//   R_L_w = diag(1, -1, -1) Rz(-heading0),  p_L = R_L_w p_w_b,  R_L_v = R_L_w R_w_b R_b_v,
//   v_v = (R_w_b R_b_v)^T v_w,  omega_v = R_b_v^T omega_b.
//
// The position is the IMU's (the lever arm to the vehicle's reference point is the flight
// controller's parameter: EKF2_EV_POS_* / VISO_POS_*). The heading is taken without atan2.

#include <cstdint>
#include <limits>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/mavlink/messages.hpp"

namespace ums::mavlink {

struct BodyState {
  std::int64_t t_ns = 0;
  Eigen::Vector3d p_w_b = Eigen::Vector3d::Zero();                // m
  Eigen::Quaterniond q_w_b = Eigen::Quaterniond::Identity();
  Eigen::Vector3d v_w_b = Eigen::Vector3d::Zero();                // m/s
  // rad/s, body rates; NaN where not known (the frame-rate output has none).
  Eigen::Vector3d omega_b = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
};

class FrdConverter {
 public:
  explicit FrdConverter(const Eigen::Matrix3d& R_b_v);
  // Fills the pose, velocity, rates, time and frame ids of *m (covariances, quality and
  // reset_counter are the caller's). The first call fixes the local frame's heading.
  void convert(const BodyState& s, Odometry* m);
  const Eigen::Matrix3d& R_L_w() const { return R_L_w_; }
  bool anchored() const { return anchored_; }

 private:
  void anchor(const Eigen::Matrix3d& R_w_v);

  Eigen::Matrix3d R_b_v_;
  Eigen::Matrix3d R_L_w_ = Eigen::Matrix3d::Identity();
  bool anchored_ = false;
};

}  // namespace ums::mavlink
