#pragma once
// Where the left image of every keyframe goes, for work done later and elsewhere (descriptors
// for a keyframe database). The view is the source's memory and valid during the call only: a
// sink that keeps the pixels copies them into a buffer of its own, allocated at start-up.

#include <cstdint>

#include "core/common/image_view.hpp"
#include "core/estimator/frame_id.hpp"

namespace ums {

class KeyframeImageSink {
 public:
  virtual ~KeyframeImageSink() = default;
  // id: the estimator's name of the frame (EstimatorOutput::frame_id); t_ns: its time on the IMU
  // clock; left: the cam0 image of that frame.
  virtual void on_keyframe_image(FrameId id, std::int64_t t_ns, const ImageView& left) = 0;
};

}  // namespace ums
