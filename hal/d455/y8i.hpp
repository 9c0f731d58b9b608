#pragma once
// De-interleave of V4L2_PIX_FMT_Y8I ('Y8I '): 16 bits per pixel, byte 0 = left imager, byte 1 = right
// imager (kernel pixfmt-y8i.rst). One pass, no intermediate copy; NEON on aarch64.

#include <cstdint>

namespace ums::d455 {

// src: width*2 bytes of pixels per row, src_stride >= 2*width. left/right: width bytes per row.
void deinterleave_y8i(const std::uint8_t* src, int width, int height, int src_stride,
                      std::uint8_t* left, int left_stride, std::uint8_t* right, int right_stride);

// The plain scalar loop (reference for tests of the vector path).
void deinterleave_y8i_scalar(const std::uint8_t* src, int width, int height, int src_stride,
                             std::uint8_t* left, int left_stride, std::uint8_t* right,
                             int right_stride);

}  // namespace ums::d455
