#include "core/mavlink/frd_odometry.hpp"

#include <cmath>

namespace ums::mavlink {

FrdConverter::FrdConverter(const Eigen::Matrix3d& R_b_v) : R_b_v_(R_b_v) {}

void FrdConverter::anchor(const Eigen::Matrix3d& R_w_v) {
  // The vehicle's forward axis in the horizontal plane; looking straight up or down it has
  // none, and the world's x is kept.
  Eigen::Vector2d f(R_w_v(0, 0), R_w_v(1, 0));
  const double n = f.norm();
  f = n > 1e-6 ? Eigen::Vector2d(f / n) : Eigen::Vector2d::UnitX();
  Eigen::Matrix3d Rz_inv = Eigen::Matrix3d::Identity();  // Rz(-heading0)
  Rz_inv(0, 0) = f.x();
  Rz_inv(0, 1) = f.y();
  Rz_inv(1, 0) = -f.y();
  Rz_inv(1, 1) = f.x();
  const Eigen::Matrix3d flip = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
  R_L_w_ = flip * Rz_inv;
  anchored_ = true;
}

void FrdConverter::convert(const BodyState& s, Odometry* m) {
  const Eigen::Matrix3d R_w_b = s.q_w_b.normalized().toRotationMatrix();
  const Eigen::Matrix3d R_w_v = R_w_b * R_b_v_;
  if (!anchored_) anchor(R_w_v);
  const Eigen::Vector3d p = R_L_w_ * s.p_w_b;
  const Eigen::Quaterniond q(R_L_w_ * R_w_v);
  const Eigen::Vector3d v = R_w_v.transpose() * s.v_w_b;
  const Eigen::Vector3d w = R_b_v_.transpose() * s.omega_b;
  m->time_usec = s.t_ns > 0 ? static_cast<std::uint64_t>(s.t_ns / 1000) : 0;
  m->x = static_cast<float>(p.x());
  m->y = static_cast<float>(p.y());
  m->z = static_cast<float>(p.z());
  m->q[0] = static_cast<float>(q.w());
  m->q[1] = static_cast<float>(q.x());
  m->q[2] = static_cast<float>(q.y());
  m->q[3] = static_cast<float>(q.z());
  m->vx = static_cast<float>(v.x());
  m->vy = static_cast<float>(v.y());
  m->vz = static_cast<float>(v.z());
  m->rollspeed = static_cast<float>(w.x());
  m->pitchspeed = static_cast<float>(w.y());
  m->yawspeed = static_cast<float>(w.z());
  m->frame_id = kFrameLocalFrd;
  m->child_frame_id = kFrameBodyFrd;
}

}  // namespace ums::mavlink
