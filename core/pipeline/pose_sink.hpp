#pragma once
// Where the pipeline's poses go (a trajectory file, a live consumer, a test). Called from the
// pipeline's thread only when a pose exists; the arguments are valid during the call only.

#include <cstdint>

namespace ums {

struct EstimatorOutput;  // core/estimator/estimator.hpp
struct NavState;         // core/imu/propagation.hpp

class PoseSink {
 public:
  virtual ~PoseSink() = default;
  // The optimized pose of one frame (camera rate): out.valid is true; out.t_ns is the frame's
  // time on the IMU clock (the source's stamp + rig td_s).
  virtual void on_frame_pose(const EstimatorOutput& out) = 0;
  // The IMU-rate pose: the last frame's estimate propagated to the sample at t_ns (IMU clock).
  virtual void on_imu_pose(std::int64_t t_ns, const NavState& state) = 0;
};

}  // namespace ums
