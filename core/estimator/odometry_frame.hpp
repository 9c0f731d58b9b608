#pragma once
// The estimator's output frame. The window estimates T_odom_b in its odometry frame (levelled to
// gravity at initialization, never moved after); what leaves the estimator is
// T_w_b = T_w_odom * T_odom_b. T_w_odom is the identity until loop closure or a loaded map
// moves it: a correction then changes the output, never the window's states.

#include <cstdint>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ums {

class OdometryFrame {
 public:
  const Eigen::Isometry3d& T_w_odom() const { return T_w_odom_; }
  // A new world placement (loop closure, relocalization); counted for consumers (reset_counter).
  void set_T_w_odom(const Eigen::Isometry3d& T_w_odom) {
    T_w_odom_ = T_w_odom;
    q_w_odom_ = Eigen::Quaterniond(T_w_odom.linear()).normalized();
    ++resets_;
  }
  std::uint32_t resets() const { return resets_; }

  Eigen::Vector3d p_w(const Eigen::Vector3d& p_odom) const { return T_w_odom_ * p_odom; }
  Eigen::Quaterniond q_w(const Eigen::Quaterniond& q_odom) const { return q_w_odom_ * q_odom; }
  Eigen::Vector3d v_w(const Eigen::Vector3d& v_odom) const { return T_w_odom_.linear() * v_odom; }

 private:
  Eigen::Isometry3d T_w_odom_ = Eigen::Isometry3d::Identity();
  Eigen::Quaterniond q_w_odom_ = Eigen::Quaterniond::Identity();
  std::uint32_t resets_ = 0;
};

}  // namespace ums
