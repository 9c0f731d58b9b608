#include "core/imu/imu_noise.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "core/common/calibration.hpp"

namespace ums {

ImuNoise ImuNoise::from_calibration(const ImuCalibration& calib) {
  ImuNoise n;
  n.gyro_noise_density = calib.gyro_noise_density;
  n.accel_noise_density = calib.accel_noise_density;
  n.gyro_random_walk = calib.gyro_random_walk;
  n.accel_random_walk = calib.accel_random_walk;
  return n;
}

void ImuNoise::validate() const {
  const struct {
    const char* name;
    double value;
  } fields[] = {{"gyro_noise_density", gyro_noise_density},
                {"accel_noise_density", accel_noise_density},
                {"gyro_random_walk", gyro_random_walk},
                {"accel_random_walk", accel_random_walk}};
  for (const auto& f : fields) {
    // Zero would make the preintegration covariance singular; the residual needs its inverse.
    if (!(std::isfinite(f.value) && f.value > 0.0)) {
      throw std::invalid_argument(std::string("ImuNoise.") + f.name +
                                  " must be finite and > 0, got " + std::to_string(f.value));
    }
  }
}

}  // namespace ums
