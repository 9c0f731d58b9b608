#pragma once
// NOMINAL calibration of a D455 in our frames, for a first run before a per-unit calibration
// (factory tables or Kalibr). Per-unit values differ by a few px and mm: do not use these for
// accuracy claims. Sources: notes §5.4 (rectified IR intrinsics of one unit, ORB-SLAM3
// RealSense_D455.yaml; IMU noise from OpenVINS's Allan analysis) and §5.3 (LRS CAD extrinsics).
//
// Frames: body = the D455 IMU re-expressed in the left-IR optical axes (iio_imu.hpp), so
// R_b_c0 = I and p_b_c0 = camera origin in that frame = (-0.03022, 0.0074, 0.01602) m (LRS CAD
// depth->IMU translation, applied after the diag(-1,1,-1) alignment). cam1 sits +baseline along x
// of cam0 (Y8I halves are rectified, row-aligned, same intrinsics, zero distortion).

#include "core/common/calibration.hpp"

namespace ums::d455 {

inline constexpr double kD455NominalBaselineM = 0.095;  // m; one unit's table says 94.96 mm

// width x height: 848x480 or 640x480 (other sizes: throws std::invalid_argument).
// imu_rate_hz: the fused IMU rate = the gyro rate (200 or 400).
RigCalibration d455_nominal_calibration(int width, int height, double fps, double imu_rate_hz);

}  // namespace ums::d455
