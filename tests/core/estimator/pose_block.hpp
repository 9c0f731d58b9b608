#pragma once
// The estimator's pose block layout (7 doubles: p, then q.x, q.y, q.z, q.w) for tests.

#include <Eigen/Geometry>

namespace ums::test {

inline void set_pose(double* x, const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  x[0] = p.x(); x[1] = p.y(); x[2] = p.z();
  x[3] = q.x(); x[4] = q.y(); x[5] = q.z(); x[6] = q.w();
}

inline Eigen::Isometry3d iso(const double* x) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(x[6], x[3], x[4], x[5]).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x[0], x[1], x[2]);
  return T;
}

}  // namespace ums::test
