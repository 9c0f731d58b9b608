#pragma once
// Hands every pose to up to three sinks (the pose files, a live consumer such as the MAVLink
// output, the map-frame poses of loop closure); a null slot is skipped. Fixed, no allocation.

#include <cstdint>

#include "core/pipeline/pose_sink.hpp"

namespace ums {

class PoseFanout final : public PoseSink {
 public:
  void set(int slot, PoseSink* sink) { sinks_[slot] = sink; }
  void on_frame_pose(const EstimatorOutput& out) override {
    for (PoseSink* s : sinks_)
      if (s != nullptr) s->on_frame_pose(out);
  }
  void on_imu_pose(std::int64_t t_ns, const NavState& state) override {
    for (PoseSink* s : sinks_)
      if (s != nullptr) s->on_imu_pose(t_ns, state);
  }

 private:
  PoseSink* sinks_[3] = {nullptr, nullptr, nullptr};
};

}  // namespace ums
