#pragma once
// One IMU measurement in the body (IMU) frame, on the pipeline's single clock.

#include <cstdint>

#include <Eigen/Core>

namespace ums {

struct ImuSample {
  std::int64_t t_ns = 0;                                  // pipeline clock, nanoseconds
  Eigen::Vector3d gyro_rad_s = Eigen::Vector3d::Zero();   // angular rate, rad/s, body frame
  Eigen::Vector3d accel_m_s2 = Eigen::Vector3d::Zero();   // specific force, m/s^2, body frame
};

}  // namespace ums
