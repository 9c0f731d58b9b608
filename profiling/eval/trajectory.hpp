#pragma once
// Timestamped pose sequences and the readers of the trajectory formats the project meets:
// TUM (`t[s] x y z qx qy qz qw`), EuRoC `state_groundtruth_estimate0/data.csv` (body = IMU in the
// world, q stored w,x,y,z) and the shared `*_GT.txt` (cam0 position, q = R_CW world -> camera).
// Tool code (start-up / offline): std::vector and exceptions are fine here.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ums::eval {

// One pose T_w_x of some frame x (body or cam0, see Trajectory::frame) at t_ns.
struct StampedPose {
  std::int64_t t_ns = 0;
  Eigen::Vector3d p_w_x = Eigen::Vector3d::Zero();            // m
  Eigen::Quaterniond q_w_x = Eigen::Quaterniond::Identity();  // x -> w (Eigen stores x,y,z,w)
};

enum class PoseFrame : std::uint8_t { kBody, kCam0 };

struct Trajectory {
  PoseFrame frame = PoseFrame::kBody;  // which frame x the poses place in the world
  std::vector<StampedPose> poses;      // sorted by t_ns, strictly increasing
};

enum class TrajectoryFormat : std::uint8_t { kAuto, kTum, kEurocCsv, kSharedGt };

// Reads a trajectory; kAuto decides by content: comma-separated with 8 columns -> shared GT
// (cam0, q = R_CW), comma-separated with >= 17 columns -> EuRoC ground truth (body), whitespace
// separated with 8 columns -> TUM (body). Throws std::runtime_error naming file and line.
Trajectory read_trajectory(const std::string& path, TrajectoryFormat format = TrajectoryFormat::kAuto);

Trajectory read_tum(const std::string& path);
Trajectory read_euroc_csv(const std::string& path);
Trajectory read_shared_gt(const std::string& path);

// Writes TUM (`t[s] x y z qx qy qz qw`, 9 decimals on t). Throws on I/O failure.
void write_tum(const std::string& path, const Trajectory& trajectory);

// Returns the trajectory of frame y rigidly attached to x: T_w_y = T_w_x * T_x_y.
Trajectory change_frame(const Trajectory& in, const Eigen::Isometry3d& T_x_y, PoseFrame out_frame);

// The trajectory placing `frame` instead: unchanged when it already does, else moved with the cam0
// extrinsic T_b_c0 (cam0 -> body) or its inverse.
Trajectory to_frame(const Trajectory& in, PoseFrame frame, const Eigen::Isometry3d& T_b_c0);

// EuRoC cam0 extrinsic of the VI-Sensor (sensor.yaml T_BS of cam0): T_b_c0, cam0 -> body.
Eigen::Isometry3d euroc_T_b_c0();

// Reads `T_BS` from an EuRoC/Kalibr sensor.yaml (the 16 numbers after `data:`). Throws.
Eigen::Isometry3d read_T_BS(const std::string& sensor_yaml_path);

}  // namespace ums::eval
