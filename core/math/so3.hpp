#pragma once
// SO(3) on rotation matrices and unit quaternions (Hamilton): hat/vee, exponential and logarithm,
// and the left/right Jacobians with their inverses. Conventions (docs/math-imu.md):
//   Exp(phi) = I + sin(t)/t [phi]x + (1 - cos(t))/t^2 [phi]x^2,   t = |phi|
//   Exp(phi + d) ~= Exp(phi) Exp(Jr(phi) d)  ~=  Exp(Jl(phi) d) Exp(phi)
// Every function is branch-stable at t -> 0 (Taylor series) and log() is accurate near t -> pi
// (axis from the symmetric part instead of the vanishing antisymmetric part).

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ums::so3 {

// [v]x: the cross-product matrix, hat(a) * b = a x b.
Eigen::Matrix3d hat(const Eigen::Vector3d& v);
// Inverse of hat() for a skew-symmetric matrix (uses the antisymmetric part of m).
Eigen::Vector3d vee(const Eigen::Matrix3d& m);

// Rotation vector (rad) -> rotation matrix.
Eigen::Matrix3d exp(const Eigen::Vector3d& phi);
// Rotation vector (rad) -> unit quaternion, w >= 0 for |phi| <= pi.
Eigen::Quaterniond exp_quat(const Eigen::Vector3d& phi);
// Rotation matrix -> rotation vector with |phi| in [0, pi].
Eigen::Vector3d log(const Eigen::Matrix3d& R);
// Unit quaternion -> rotation vector with |phi| in [0, pi] (q and -q give the same result).
Eigen::Vector3d log(const Eigen::Quaterniond& q);

// Right Jacobian Jr(phi) and its inverse: Exp(phi + d) ~= Exp(phi) Exp(Jr(phi) d).
Eigen::Matrix3d right_jacobian(const Eigen::Vector3d& phi);
Eigen::Matrix3d right_jacobian_inverse(const Eigen::Vector3d& phi);
// Left Jacobian Jl(phi) = Jr(-phi) and its inverse: Exp(phi + d) ~= Exp(Jl(phi) d) Exp(phi).
Eigen::Matrix3d left_jacobian(const Eigen::Vector3d& phi);
Eigen::Matrix3d left_jacobian_inverse(const Eigen::Vector3d& phi);

// Angle of a rotation in radians, in [0, pi].
double angle(const Eigen::Matrix3d& R);
double angle(const Eigen::Quaterniond& q);

}  // namespace ums::so3
