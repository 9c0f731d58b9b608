#pragma once
// State prediction from IMU samples (paper Section III-A.2 "propagation"): the IMU-rate output
// between optimised frames and the IMU-only mode. Same midpoint rule as the preintegration, in
// the world frame with gravity:
//   a_k = R_k (f_k - b_a) + g_w,  R_k+1 = R_k Exp((w_k + w_k+1)/2 - b_g) dt),
//   p += v dt + 1/2 (a_k + a_k+1)/2 dt^2,  v += (a_k + a_k+1)/2 dt.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>

#include "core/common/imu_sample.hpp"
#include "core/common/status.hpp"

namespace ums {

class Preintegration;

struct NavState {
  std::int64_t t_ns = 0;                                      // pipeline clock
  Eigen::Vector3d p_w_b = Eigen::Vector3d::Zero();            // m
  Eigen::Quaterniond q_w_b = Eigen::Quaterniond::Identity();  // body -> world (x,y,z,w in memory)
  Eigen::Vector3d v_w_b = Eigen::Vector3d::Zero();            // m/s, in world
  Eigen::Vector3d ba = Eigen::Vector3d::Zero();               // accel bias, m/s^2
  Eigen::Vector3d bg = Eigen::Vector3d::Zero();               // gyro bias, rad/s
};

class ImuPropagator {
 public:
  explicit ImuPropagator(const Eigen::Vector3d& g_w = Eigen::Vector3d(0.0, 0.0, -9.81));

  // Restarts from a state valid at last_sample.t_ns (state.t_ns is overwritten with it).
  void reset(const NavState& state, const ImuSample& last_sample);
  // Advances to sample.t_ns. kInvalidInput (state unchanged) if not reset, not finite or not
  // after the previous sample.
  Status propagate(const ImuSample& sample);

  const NavState& state() const { return state_; }
  bool initialized() const { return initialized_; }

 private:
  Eigen::Vector3d g_w_;
  NavState state_;
  ImuSample last_;
  bool initialized_ = false;
};

// State at j from the state at i and a preintegration i->j (biases kept, deltas corrected for
// the biases of i): the prediction the residual of eq. (1) is zero at.
NavState predict(const NavState& state_i, const Preintegration& preintegration,
                 const Eigen::Vector3d& g_w);

}  // namespace ums
