#pragma once
// The pipeline's poses as TUM lines (t_s x y z qx qy qz qw, body = IMU in world): camera-rate
// poses into one file, IMU-rate poses into another. stdio into a buffered FILE allocates
// nothing per line. A third stream, states.csv, holds what a pose does not: the mode, velocity
// and the IMU biases per frame (how well the biases converge is the first thing to look at when
// yaw drifts). The caller owns the files; nullptr: that stream is not written.

#include <cstdint>
#include <cstdio>

#include "core/pipeline/pose_sink.hpp"

namespace ums::cli {

class TumPoseSink final : public PoseSink {
 public:
  void set_trajectory_output(std::FILE* file) { trajectory_ = file; }
  void set_imu_pose_output(std::FILE* file) { imu_poses_ = file; }
  void set_state_output(std::FILE* file) { states_ = file; }
  // The header line of the states stream.
  static const char* state_header();
  // Camera-rate poses the pipeline produced (whether or not a trajectory file was set).
  std::uint64_t poses_written() const { return poses_written_; }

  void on_frame_pose(const EstimatorOutput& out) override;
  void on_imu_pose(std::int64_t t_ns, const NavState& state) override;

 private:
  std::FILE* trajectory_ = nullptr;
  std::FILE* imu_poses_ = nullptr;
  std::FILE* states_ = nullptr;
  std::uint64_t poses_written_ = 0;
};

}  // namespace ums::cli
