#pragma once
// A non-owning view of an 8-bit grey image. Owners (hal buffers, pyramids) allocate once at
// start-up; the pipeline passes views.

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace ums {

struct ImageView {
  const std::uint8_t* data = nullptr;
  int width = 0;       // px
  int height = 0;      // px
  int stride = 0;      // bytes between rows
  // px that may be read outside each edge (rows -margin .. height + margin - 1, columns likewise),
  // each a copy of the nearest edge pixel: what a reader clamping its coordinates would see.
  int margin = 0;

  bool valid() const { return data != nullptr && width > 0 && height > 0 && stride >= width; }
  const std::uint8_t* row(int y) const { return data + static_cast<long>(y) * stride; }
};

// Copies src's pixels into dst, rows packed (stride = width; dst holds width * height bytes), and
// returns the view of the copy: for a frame kept past its source's next one.
inline ImageView copy_packed(const ImageView& src, std::uint8_t* dst) {
  const std::size_t w = static_cast<std::size_t>(src.width);
  for (int y = 0; y < src.height; ++y) std::memcpy(dst + static_cast<std::size_t>(y) * w, src.row(y), w);
  return ImageView{dst, src.width, src.height, src.width};
}

}  // namespace ums
