#pragma once
// Stable identity of a window frame: monotonic over a run, never reused (slot numbers are). The
// prior's blocks, the keyframe outlet and, later, the keyframe database name frames by it.

#include <cstdint>

namespace ums {

using FrameId = std::uint32_t;
inline constexpr FrameId kNoFrame = 0xFFFFFFFFu;

}  // namespace ums
