#pragma once
// What each parameter block of the current solver problem is: a frame's pose or speed-bias
// (named by FrameId, which outlives slots), an extrinsic (by camera) or a landmark. The prior's
// blocks are remembered by these names between problems.

#include <cstdint>
#include <memory>

#include "core/estimator/frame_id.hpp"
#include "solver/capacity.hpp"

namespace ums {

// kRelocation: the loop keyframe's pose of a tightly coupled relocation (relocation.hpp), never
// in the prior. kTimeOffset: the camera-IMU offset (time_offset.hpp), owner 0. kGyroScale: the
// gyro's scale-factor error (gyro_scale.hpp), owner 0.
enum class BlockKind : std::uint8_t {
  kPose = 0,
  kSpeedBias = 1,
  kExtrinsic = 2,
  kLandmark = 3,
  kRelocation = 4,
  kTimeOffset = 5,
  kGyroScale = 6
};

struct BlockName {
  BlockKind kind = BlockKind::kLandmark;
  std::uint32_t owner = 0;  // FrameId for kPose / kSpeedBias / kRelocation, camera for kExtrinsic
};

class BlockTable {
 public:
  BlockTable() : names_(new BlockName[solver::capacity::kMaxParameterBlocks]) {}
  void note(int id, BlockKind kind, std::uint32_t owner) { names_[id] = BlockName{kind, owner}; }
  const BlockName& operator[](int id) const { return names_[id]; }

 private:
  std::unique_ptr<BlockName[]> names_;
};

}  // namespace ums
