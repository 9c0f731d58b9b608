#include "hal/d455/y8i.hpp"

#if defined(__ARM_NEON)
#include <arm_neon.h>
#endif

namespace ums::d455 {

void deinterleave_y8i_scalar(const std::uint8_t* src, int width, int height, int src_stride,
                             std::uint8_t* left, int left_stride, std::uint8_t* right,
                             int right_stride) {
  for (int y = 0; y < height; ++y) {
    const std::uint8_t* s = src + static_cast<long>(y) * src_stride;
    std::uint8_t* l = left + static_cast<long>(y) * left_stride;
    std::uint8_t* r = right + static_cast<long>(y) * right_stride;
    for (int x = 0; x < width; ++x) {
      l[x] = s[2 * x];
      r[x] = s[2 * x + 1];
    }
  }
}

void deinterleave_y8i(const std::uint8_t* src, int width, int height, int src_stride,
                      std::uint8_t* left, int left_stride, std::uint8_t* right, int right_stride) {
#if defined(__ARM_NEON)
  for (int y = 0; y < height; ++y) {
    const std::uint8_t* s = src + static_cast<long>(y) * src_stride;
    std::uint8_t* l = left + static_cast<long>(y) * left_stride;
    std::uint8_t* r = right + static_cast<long>(y) * right_stride;
    int x = 0;
    // vld2q splits 32 interleaved bytes into the even (left) and odd (right) lanes in one load.
    for (; x + 16 <= width; x += 16) {
      uint8x16x2_t lr = vld2q_u8(s + 2 * x);
      vst1q_u8(l + x, lr.val[0]);
      vst1q_u8(r + x, lr.val[1]);
    }
    for (; x < width; ++x) {
      l[x] = s[2 * x];
      r[x] = s[2 * x + 1];
    }
  }
#else
  deinterleave_y8i_scalar(src, width, height, src_stride, left, left_stride, right, right_stride);
#endif
}

}  // namespace ums::d455
