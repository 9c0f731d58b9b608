#pragma once
// Continuous-time IMU noise model (Kalibr/EuRoC sensor.yaml units). Discrete values follow from
// the sample interval dt: white-noise std per sample = density / sqrt(dt); bias random-walk std
// per sample = random_walk * sqrt(dt). See docs/math-imu.md.

namespace ums {

struct ImuCalibration;

struct ImuNoise {
  double gyro_noise_density = 1.6968e-04;  // rad/s/sqrt(Hz)   (EuRoC ADIS16448 defaults)
  double accel_noise_density = 2.0e-3;     // m/s^2/sqrt(Hz)
  double gyro_random_walk = 1.9393e-05;    // rad/s^2/sqrt(Hz)
  double accel_random_walk = 3.0e-3;       // m/s^3/sqrt(Hz)

  static ImuNoise from_calibration(const ImuCalibration& calib);
  void validate() const;  // throws std::invalid_argument naming the field and value
};

}  // namespace ums
