// The V4L2 Y8I frame splitter on frames of any geometry the camera's format check lets through
// (v4l2_camera.cpp: bytesperline >= 2 * width, buffer >= bytesperline * height): the first three
// bytes choose width 1..256, height 1..64 and row padding 0..63, the rest is the frame, padded
// with zeros or cut to the size the driver announced.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "hal/d455/y8i.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 3) return 0;
  const int width = 1 + data[0];
  const int height = 1 + (data[1] & 63);
  const int stride = 2 * width + (data[2] & 63);
  // Exactly sizeimage bytes, so ASan sees any read past the driver's buffer.
  std::vector<std::uint8_t> frame(static_cast<std::size_t>(stride) * static_cast<std::size_t>(height));
  std::memcpy(frame.data(), data + 3, std::min(frame.size(), size - 3));
  std::vector<std::uint8_t> left(static_cast<std::size_t>(width * height));
  std::vector<std::uint8_t> right(left.size());
  ums::d455::deinterleave_y8i(frame.data(), width, height, stride, left.data(), width, right.data(), width);
  // The vector path must agree with the scalar reference.
  std::vector<std::uint8_t> left_ref(left.size()), right_ref(left.size());
  ums::d455::deinterleave_y8i_scalar(frame.data(), width, height, stride, left_ref.data(), width,
                                     right_ref.data(), width);
  if (left != left_ref || right != right_ref) __builtin_trap();
  return 0;
}
