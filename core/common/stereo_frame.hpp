#pragma once
// A synchronized stereo pair: two grey images sharing one timestamp. Views only; the source owns
// the pixels until the next frame is requested.

#include <cstdint>

#include "core/common/image_view.hpp"

namespace ums {

struct StereoFrame {
  std::int64_t t_ns = 0;   // pipeline clock, nanoseconds (exposure middle where the source knows it)
  std::int64_t td_ns = 0;  // the camera-IMU offset already added to t_ns (TimeAligner); 0 from a source
  std::uint64_t seq = 0;   // index of the pair in its source, 0-based
  ImageView left;          // cam0
  ImageView right;         // cam1; invalid (data == nullptr) when the right image is missing
};

}  // namespace ums
