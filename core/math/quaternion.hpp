#pragma once
// Hamilton quaternion helpers. Eigen::Quaterniond stores its coefficients in memory as
// (x, y, z, w); the 4x4 product matrices below act on 4-vectors ordered [w, x, y, z] (scalar
// first, as written in the papers), see to_wxyz()/from_wxyz().

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ums::quat {

// [w, x, y, z] <-> Eigen::Quaterniond (no normalisation).
Eigen::Vector4d to_wxyz(const Eigen::Quaterniond& q);
Eigen::Quaterniond from_wxyz(const Eigen::Vector4d& wxyz);

// Left/right product matrices: to_wxyz(p * q) = left(p) * to_wxyz(q) = right(q) * to_wxyz(p).
Eigen::Matrix4d left(const Eigen::Quaterniond& p);
Eigen::Matrix4d right(const Eigen::Quaterniond& q);

// Unit quaternion with non-negative w (the same rotation as q); identity if q is ~zero.
Eigen::Quaterniond normalized_positive(const Eigen::Quaterniond& q);

// Small-angle delta quaternion [1, dtheta/2] normalised: first-order equal to Exp(dtheta) and
// cheaper; use so3::exp_quat when the angle may be large.
Eigen::Quaterniond small_angle(const Eigen::Vector3d& dtheta_rad);

// Rotation with the same roll and pitch as R_w_b (ZYX Euler) and zero yaw.
Eigen::Matrix3d remove_yaw(const Eigen::Matrix3d& R_w_b);
// Yaw (rad) of R_w_b: the heading of the body x axis projected on the world x-y plane (ZYX Euler).
double yaw(const Eigen::Matrix3d& R_w_b);
// An angle (rad) wrapped into (-pi, pi].
double wrap_angle_rad(double a_rad);

}  // namespace ums::quat
