#pragma once
// state_groundtruth_estimate0/data.csv of the EuRoC layout: one body state per row,
//   t [ns], p_w_b (x y z) [m], q_w_b (w x y z) [], v_w_b (x y z) [m/s],
//   gyro bias (x y z) [rad/s], accel bias (x y z) [m/s^2]      (17 columns)
// read row by row in bounded memory, and the row format used by the writer.

#include <cstdint>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "hal/replay/csv_reader.hpp"

namespace ums::hal {

struct GroundTruthState {
  std::int64_t t_ns = 0;
  Eigen::Vector3d p_w_b = Eigen::Vector3d::Zero();              // m, body (IMU) in world
  Eigen::Quaterniond q_w_b = Eigen::Quaterniond::Identity();    // body -> world (Eigen stores x,y,z,w)
  Eigen::Vector3d v_w_b = Eigen::Vector3d::Zero();              // m/s, in world
  Eigen::Vector3d gyro_bias_rad_s = Eigen::Vector3d::Zero();    // rad/s
  Eigen::Vector3d accel_bias_m_s2 = Eigen::Vector3d::Zero();    // m/s^2
};

inline constexpr const char* kEurocGroundtruthHeader =
    "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], "
    "q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], "
    "b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], "
    "b_a_RS_S_z [m s^-2]";

class EurocGroundtruthReader {
 public:
  void open(const std::string& path);  // throws "<path>: cannot open (...)"
  // kRow with *state filled, kEnd, or kError with error() = "<path>:<line>: ..." (wrong column
  // count, non-numeric value, non-increasing timestamp, quaternion far from unit norm).
  CsvReader::Result next(GroundTruthState* state);
  const char* error() const { return csv_.error(); }

 private:
  CsvReader csv_;
  std::int64_t previous_t_ns_ = 0;
  long previous_line_ = 0;
};

}  // namespace ums::hal
