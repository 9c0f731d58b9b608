#include "core/frontend/image_pyramid.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

namespace ums {

ImagePyramid::ImagePyramid(int width, int height, int levels, int margin_px) : levels_(levels) {
  if (width <= 0 || height <= 0 || width > capacity::kMaxImageWidth || height > capacity::kMaxImageHeight) {
    throw std::runtime_error("ImagePyramid: image size " + std::to_string(width) + "x" + std::to_string(height) +
                             " outside 1.." + std::to_string(capacity::kMaxImageWidth) + "x" +
                             std::to_string(capacity::kMaxImageHeight));
  }
  if (levels < 1 || levels > capacity::kMaxPyramidLevels) {
    throw std::runtime_error("ImagePyramid: levels " + std::to_string(levels) + " outside 1.." +
                             std::to_string(capacity::kMaxPyramidLevels));
  }
  if (margin_px < 0 || margin_px > capacity::kPyramidMarginPx) {
    throw std::runtime_error("ImagePyramid: margin " + std::to_string(margin_px) + " px outside 0.." +
                             std::to_string(capacity::kPyramidMarginPx));
  }
  const int m = margin_px;
  std::size_t total = 0;
  int w = width, h = height;
  for (int l = 0; l < levels; ++l) {
    total += static_cast<std::size_t>(w + 2 * m) * static_cast<std::size_t>(h + 2 * m);
    w = std::max(1, (w + 1) / 2);
    h = std::max(1, (h + 1) / 2);
  }
  storage_.assign(total, 0);
  row_tmp_.assign(static_cast<std::size_t>(width), 0);
  std::size_t offset = 0;
  w = width;
  h = height;
  for (int l = 0; l < levels; ++l) {
    ImageView& v = views_[l];
    v.stride = w + 2 * m;
    v.data = storage_.data() + offset + static_cast<std::size_t>(m) * static_cast<std::size_t>(v.stride) +
             static_cast<std::size_t>(m);
    v.width = w;
    v.height = h;
    v.margin = m;
    offset += static_cast<std::size_t>(v.stride) * static_cast<std::size_t>(h + 2 * m);
    w = std::max(1, (w + 1) / 2);
    h = std::max(1, (h + 1) / 2);
  }
}

namespace {

// dst(x, y) = blur(src)(2x, 2y) with the 5-tap binomial kernel and replicated borders. The
// vertical pass runs first into row_tmp (sums up to 16*255 fit uint16), then the horizontal one.
void downsample(const ImageView& src, const ImageView& dst, std::uint16_t* row_tmp) {
  static constexpr int kW[5] = {1, 4, 6, 4, 1};
  const int sw = src.width, sh = src.height;
  auto* out_base = const_cast<std::uint8_t*>(dst.data);  // the pyramid owns these bytes
  for (int y = 0; y < dst.height; ++y) {
    const int sy = 2 * y;
    const std::uint8_t* rows[5];
    for (int k = 0; k < 5; ++k) rows[k] = src.row(std::clamp(sy + k - 2, 0, sh - 1));
    for (int x = 0; x < sw; ++x) {
      row_tmp[x] = static_cast<std::uint16_t>(rows[0][x] + 4 * rows[1][x] + 6 * rows[2][x] + 4 * rows[3][x] + rows[4][x]);
    }
    std::uint8_t* out = out_base + static_cast<long>(y) * dst.stride;
    // Columns whose five taps lie inside the row run in a loop of their own (no border test,
    // 16-bit lanes: 16 * 255 * 16 + 128 < 2^16); the one or two at each end clamp.
    const int x_lo = std::min(1, dst.width), x_hi = std::max(x_lo, std::min(dst.width, (sw - 1) / 2));
    auto clamped = [&](int x) {
      int acc = 0;
      for (int k = 0; k < 5; ++k) acc += kW[k] * row_tmp[std::clamp(2 * x + k - 2, 0, sw - 1)];
      out[x] = static_cast<std::uint8_t>((acc + 128) >> 8);
    };
    for (int x = 0; x < x_lo; ++x) clamped(x);
    const std::uint16_t* __restrict t = row_tmp;
    std::uint8_t* __restrict o = out;
    for (int x = x_lo; x < x_hi; ++x) {
      const int sx = 2 * x;
      const std::uint16_t acc = static_cast<std::uint16_t>(t[sx - 2] + 4 * t[sx - 1] + 6 * t[sx] + 4 * t[sx + 1] + t[sx + 2] + 128);
      o[x] = static_cast<std::uint8_t>(acc >> 8);
    }
    for (int x = x_hi; x < dst.width; ++x) clamped(x);
  }
}

// Row r's ends repeated m pixels sideways (M: m known at compile time, the stores inlined).
template <int M>
inline void fill_sides(std::uint8_t* r, int width, int m) {
  std::memset(r - (M > 0 ? M : m), r[0], static_cast<std::size_t>(M > 0 ? M : m));
  std::memset(r + width, r[width - 1], static_cast<std::size_t>(M > 0 ? M : m));
}

// The margin around v's pixels: each row's ends repeated sideways, then the first and last rows
// (margins included) repeated up and down, so a margin pixel is the image's pixel at the clamped
// coordinates.
void fill_margin(const ImageView& v) {
  const int m = v.margin;
  if (m == 0) return;
  auto* first = const_cast<std::uint8_t*>(v.row(0));  // the pyramid owns these bytes
  for (int y = 0; y < v.height; ++y) {
    std::uint8_t* r = first + static_cast<long>(y) * v.stride;
    if (m == capacity::kPyramidMarginPx)
      fill_sides<capacity::kPyramidMarginPx>(r, v.width, m);
    else
      fill_sides<0>(r, v.width, m);
  }
  const std::size_t bytes = static_cast<std::size_t>(v.stride);
  std::uint8_t* last = first + static_cast<long>(v.height - 1) * v.stride;
  for (int k = 1; k <= m; ++k) {
    std::memcpy(first - static_cast<long>(k) * v.stride - m, first - m, bytes);
    std::memcpy(last + static_cast<long>(k) * v.stride - m, last - m, bytes);
  }
}

}  // namespace

Status ImagePyramid::build(const ImageView& image) {
  const ImageView& l0 = views_[0];
  if (!image.valid() || image.width != l0.width || image.height != l0.height) return Status::kInvalidInput;
  ++generation_;
  auto* dst = const_cast<std::uint8_t*>(l0.data);
  for (int y = 0; y < l0.height; ++y) std::memcpy(dst + static_cast<long>(y) * l0.stride, image.row(y), static_cast<std::size_t>(l0.width));
  for (int l = 1; l < levels_; ++l) downsample(views_[l - 1], views_[l], row_tmp_.data());
  for (int l = 0; l < levels_; ++l) fill_margin(views_[l]);
  return Status::kOk;
}

}  // namespace ums
