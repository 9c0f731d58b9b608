#pragma once
// Where the left image of every keyframe goes, with the features tracked in it, for work done
// later and elsewhere (descriptors for a keyframe database). The view and the features are the
// pipeline's memory and valid during the call only: a sink copies what it keeps into buffers of
// its own, allocated at start-up.

#include <cstdint>

#include "core/common/image_view.hpp"
#include "core/estimator/frame_id.hpp"
#include "core/frontend/frame_features.hpp"

namespace ums {

class KeyframeImageSink {
 public:
  virtual ~KeyframeImageSink() = default;
  // id: the estimator's name of the frame (EstimatorOutput::frame_id); t_ns: its time on the IMU
  // clock; left: the cam0 image of that frame; features: the front end's features of that frame.
  virtual void on_keyframe_image(FrameId id, std::int64_t t_ns, const ImageView& left,
                                 const FrameFeatures& features) = 0;
};

}  // namespace ums
