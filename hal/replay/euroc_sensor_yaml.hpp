#pragma once
// The sensor.yaml files of the EuRoC/ASL layout (mav0/cam0/sensor.yaml, mav0/imu0/sensor.yaml):
// read into and written from the core calibration structs. Start-up code; throws
// std::runtime_error naming the file and key on bad content.
//
// Camera keys: T_BS {rows: 4, cols: 4, data: [16, row-major]} (sensor -> body), rate_hz,
// resolution [w, h], camera_model (pinhole), intrinsics [fu, fv, cu, cv],
// distortion_model (radial-tangential | equidistant; also radtan, equi), distortion_coefficients
// [4]. IMU keys: T_BS, rate_hz, gyroscope_noise_density, gyroscope_random_walk,
// accelerometer_noise_density, accelerometer_random_walk.

#include <string>

#include "core/common/calibration.hpp"

namespace ums::hal {

CameraCalibration read_euroc_camera_yaml(const std::string& path);
ImuCalibration read_euroc_imu_yaml(const std::string& path);  // gravity_m_s2 keeps its default

// Writes in EuRoC's own format (with the %YAML:1.0 directive), numbers with 17 significant
// digits so a read-back is exact. comment: the file's free-text "comment" value.
void write_euroc_camera_yaml(const std::string& path, const CameraCalibration& camera,
                             const std::string& comment);
void write_euroc_imu_yaml(const std::string& path, const ImuCalibration& imu,
                          const std::string& comment);

}  // namespace ums::hal
