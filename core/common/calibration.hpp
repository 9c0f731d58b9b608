#pragma once
// Sensor calibration of a stereo-inertial rig: what the sensor.yaml files of a dataset, a Kalibr
// chain or the device provide. Plain data; parsing lives at the edge (hal/, board/).

#include <array>
#include <cstdint>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ums {

enum class CameraModel : std::uint8_t { kPinholeRadTan, kPinholeEquidistant };

struct CameraCalibration {
  CameraModel model = CameraModel::kPinholeRadTan;
  int width = 0;                 // px
  int height = 0;                // px
  double rate_hz = 0.0;          // frames per second
  double fx = 0.0, fy = 0.0;     // px
  double cx = 0.0, cy = 0.0;     // px
  // radtan: k1 k2 p1 p2; equidistant: k1 k2 k3 k4
  std::array<double, 4> distortion{};
  Eigen::Isometry3d T_b_c = Eigen::Isometry3d::Identity();  // camera -> body (IMU)
};

struct ImuCalibration {
  double rate_hz = 200.0;                   // samples per second
  double gyro_noise_density = 1.6968e-04;   // rad/s/sqrt(Hz)
  double gyro_random_walk = 1.9393e-05;     // rad/s^2/sqrt(Hz)
  double accel_noise_density = 2.0e-3;      // m/s^2/sqrt(Hz)
  double accel_random_walk = 3.0e-3;        // m/s^3/sqrt(Hz)
  double gravity_m_s2 = 9.81;               // magnitude of local gravity
  Eigen::Isometry3d T_b_i = Eigen::Isometry3d::Identity();  // IMU -> body (identity: body = IMU)
};

struct RigCalibration {
  CameraCalibration cam[2];
  ImuCalibration imu;
  double td_s = 0.0;  // camera clock offset: t_imu = t_cam + td_s
};

}  // namespace ums
