#pragma once
// Reads a Kalibr calibration (camchain-imucam.yaml + imu.yaml) into a RigCalibration. Start-up
// only; throws std::runtime_error naming the file, the key and the value.
//
// Conventions (Kalibr): cam<N>.T_cam_imu maps IMU-frame points into camera N (p_c = T_cam_imu
// p_i); our T_b_c = T_cam_imu^-1 with body = the IMU frame of the recording. If the recording was
// made through this HAL, that IMU frame is already our body frame (left-IR optical axes).
// timeshift_cam_imu: t_imu = t_cam + shift, which is our td_s. intrinsics [fu, fv, pu, pv];
// distortion_model radtan [k1 k2 r1 r2] or equidistant [k1 k2 k3 k4]; camera_model pinhole only.

#include <string>

#include "core/common/calibration.hpp"

namespace ums::d455 {

// imu_yaml may be "" (noise values then keep ImuCalibration's defaults).
RigCalibration read_kalibr(const std::string& camchain_imucam_yaml, const std::string& imu_yaml);

}  // namespace ums::d455
