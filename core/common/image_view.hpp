#pragma once
// A non-owning view of an 8-bit grey image. Owners (hal buffers, pyramids) allocate once at
// start-up; the pipeline passes views.

#include <cstdint>

namespace ums {

struct ImageView {
  const std::uint8_t* data = nullptr;
  int width = 0;       // px
  int height = 0;      // px
  int stride = 0;      // bytes between rows

  bool valid() const { return data != nullptr && width > 0 && height > 0 && stride >= width; }
  const std::uint8_t* row(int y) const { return data + static_cast<long>(y) * stride; }
};

}  // namespace ums
