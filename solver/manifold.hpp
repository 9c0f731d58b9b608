#pragma once
// Manifolds of parameter blocks (docs/solver.md, conventions shared with core/imu):
//  - kEuclidean: x <- x + delta, ambient size == tangent size (speed-bias 9, inverse depth 1,
//    time offset 1, any small vector).
//  - kPose: 7 doubles [p.x, p.y, p.z, q.x, q.y, q.z, q.w] (Eigen::Quaterniond coefficient order,
//    Hamilton, q = R_w_b), 6-dof tangent [dp(3), dtheta(3)]:
//      p <- p + dp,  q <- q * Exp(dtheta)   (right perturbation, body frame).
// Residual Jacobians are always written with respect to the tangent, never the ambient values.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>

namespace ums::solver {

enum class ManifoldType : std::uint8_t { kEuclidean = 0, kPose = 1 };

inline constexpr int kPoseAmbientSize = 7;
inline constexpr int kPoseTangentSize = 6;

// Tangent size for a block of the given manifold and ambient size (pose: 6).
constexpr int tangent_size(ManifoldType m, int ambient_size) {
  return m == ManifoldType::kPose ? kPoseTangentSize : ambient_size;
}

// SO(3) exponential of a rotation vector (rad), as a unit quaternion.
Eigen::Quaterniond so3_exp(const Eigen::Vector3d& theta_rad);
// SO(3) logarithm (rad), for the shortest rotation (|theta| <= pi).
Eigen::Vector3d so3_log(const Eigen::Quaterniond& q);
// Right Jacobian of SO(3): Exp(phi + d) ~ Exp(phi) Exp(Jr(phi) d).
Eigen::Matrix3d so3_right_jacobian(const Eigen::Vector3d& phi_rad);
// Inverse of the right Jacobian of SO(3): Log(Exp(phi) Exp(d)) ~ phi + Jr^-1(phi) d.
Eigen::Matrix3d so3_right_jacobian_inverse(const Eigen::Vector3d& phi_rad);

// x_plus = x [+] delta; x_plus may alias x.
void manifold_plus(ManifoldType m, int ambient_size, const double* x, const double* delta,
                   double* x_plus);
// delta = y [-] x, the tangent vector with x [+] delta == y (pose: [p_y - p_x, Log(q_x^-1 q_y)]).
void manifold_minus(ManifoldType m, int ambient_size, const double* y, const double* x,
                    double* delta);

}  // namespace ums::solver
