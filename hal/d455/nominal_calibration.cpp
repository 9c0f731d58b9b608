#include "hal/d455/nominal_calibration.hpp"

#include <stdexcept>
#include <string>

namespace ums::d455 {

RigCalibration d455_nominal_calibration(int width, int height, double fps, double imu_rate_hz) {
  RigCalibration rig;
  CameraCalibration cam;
  cam.model = CameraModel::kPinholeRadTan;
  cam.width = width;
  cam.height = height;
  cam.rate_hz = fps;
  if (width == 848 && height == 480) {
    cam.fx = cam.fy = 429.278;
    cam.cx = 429.302;
    cam.cy = 242.071;
  } else if (width == 640 && height == 480) {
    cam.fx = cam.fy = 388.780;
    cam.cx = 324.802;
    cam.cy = 241.876;
  } else {
    throw std::invalid_argument("d455_nominal_calibration: no nominal intrinsics for " + std::to_string(width) +
                                "x" + std::to_string(height) + " (848x480 or 640x480)");
  }
  cam.distortion = {0.0, 0.0, 0.0, 0.0};  // Y8I is rectified by the firmware (notes §2.1)
  cam.T_b_c = Eigen::Isometry3d::Identity();
  cam.T_b_c.translation() = Eigen::Vector3d(-0.03022, 0.0074, 0.01602);
  rig.cam[0] = cam;
  cam.T_b_c.translation().x() += kD455NominalBaselineM;
  rig.cam[1] = cam;
  // Allan-variance values of a D455 (OpenVINS kalibr_imu_chain), inflated x2 (white noise) and
  // x10 (random walk) as OpenVINS runs them, to cover unmodelled effects.
  rig.imu.rate_hz = imu_rate_hz;
  rig.imu.accel_noise_density = 2.0 * 1.04e-3;   // m/s^2/sqrt(Hz)
  rig.imu.accel_random_walk = 10.0 * 4.13e-5;    // m/s^3/sqrt(Hz)
  rig.imu.gyro_noise_density = 2.0 * 1.03e-4;    // rad/s/sqrt(Hz)
  rig.imu.gyro_random_walk = 10.0 * 1.11e-6;     // rad/s^2/sqrt(Hz)
  rig.imu.gravity_m_s2 = 9.81;
  rig.td_s = 0.0;  // device-clock stamps on both streams; Kalibr saw 4.6-5.0 ms after LRS mapping
  return rig;
}

}  // namespace ums::d455
