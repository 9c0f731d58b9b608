#pragma once
// Layout of the estimator's state blocks, in one place (after PX4 EKF2's constexpr state table):
//   pose block        [p_w_b (3, m) | q_w_b (4, x y z w)]         = solver pose manifold, 7 doubles
//   speed-bias block  [v_w_b (3, m/s) | b_a (3, m/s^2) | b_g (3, rad/s)]  9 doubles
// Every reader writes offsets through these names and views; nobody writes `sb + 6`.

#include <cstddef>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ums::state {

inline constexpr int kPoseP = 0;      // position, m
inline constexpr int kPoseQ = 3;      // quaternion (x, y, z, w in memory: Eigen's order)
inline constexpr int kPoseSize = 7;
inline constexpr int kPoseTangent = 6;

inline constexpr int kSbV = 0;        // velocity in world, m/s
inline constexpr int kSbBa = 3;       // accelerometer bias, m/s^2
inline constexpr int kSbBg = 6;       // gyro bias, rad/s
inline constexpr int kSbSize = 9;

static_assert(kPoseP + 3 == kPoseQ && kPoseQ + 4 == kPoseSize, "pose block: p then q, contiguous");
static_assert(kSbV + 3 == kSbBa && kSbBa + 3 == kSbBg && kSbBg + 3 == kSbSize,
              "speed-bias block: v, b_a, b_g contiguous");

using ConstVec3 = Eigen::Map<const Eigen::Vector3d>;
using Vec3 = Eigen::Map<Eigen::Vector3d>;
using ConstQuat = Eigen::Map<const Eigen::Quaterniond>;
using Quat = Eigen::Map<Eigen::Quaterniond>;

inline Vec3 p(double* pose) { return Vec3(pose + kPoseP); }
inline ConstVec3 p(const double* pose) { return ConstVec3(pose + kPoseP); }
inline Quat q(double* pose) { return Quat(pose + kPoseQ); }
inline ConstQuat q(const double* pose) { return ConstQuat(pose + kPoseQ); }

inline Vec3 v(double* sb) { return Vec3(sb + kSbV); }
inline ConstVec3 v(const double* sb) { return ConstVec3(sb + kSbV); }
inline Vec3 ba(double* sb) { return Vec3(sb + kSbBa); }
inline ConstVec3 ba(const double* sb) { return ConstVec3(sb + kSbBa); }
inline Vec3 bg(double* sb) { return Vec3(sb + kSbBg); }
inline ConstVec3 bg(const double* sb) { return ConstVec3(sb + kSbBg); }

}  // namespace ums::state
