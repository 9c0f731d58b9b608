#pragma once
// 8-bit grey PNG read/write with libpng (not OpenCV imgcodecs: it cannot be co-installed for
// arm64 on Debian 12). Two levels:
//  - read_png_gray8 / write_png_gray8: one-shot functions for tools, tests and start-up code;
//  - PngGrayReader: a decoder that owns its working memory (an arena for libpng and zlib, and a
//    file buffer), so a replay loop decodes frame after frame without touching the heap.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "core/common/image_view.hpp"

namespace ums::hal {

// Reads an 8-bit grey PNG (grey+alpha, RGB(A), palette, 1/2/4/16-bit inputs are converted to
// 8-bit grey) into dst (capacity bytes, rows packed, stride = width). Returns false and fills
// *error ("<path>: <reason>") on failure; dst may then hold a partial image.
bool read_png_gray8(const std::string& path, std::uint8_t* dst, std::size_t capacity, int* width,
                    int* height, std::string* error);

// Reads only the IHDR of a PNG (24 bytes): false when the file cannot be read or is not a PNG.
// Allocates nothing.
bool read_png_size(const char* path, int* width, int* height);

// Writes image (any stride) as an 8-bit grey PNG. Returns false and fills *error on failure.
bool write_png_gray8(const std::string& path, const ImageView& image, std::string* error);

// Reusable decoder. Construction allocates its arena once; read() then allocates nothing on the
// heap as long as libpng's working set fits the arena (it does for grey/RGB images up to
// capacity::kMaxImageWidth; a larger request falls back to malloc and is counted in
// heap_fallbacks()).
class PngGrayReader {
 public:
  static constexpr std::size_t kDefaultArenaBytes = 512 * 1024;  // bytes: png/zlib state + rows

  explicit PngGrayReader(std::size_t arena_bytes = kDefaultArenaBytes);
  ~PngGrayReader();
  PngGrayReader(const PngGrayReader&) = delete;
  PngGrayReader& operator=(const PngGrayReader&) = delete;

  // As read_png_gray8; path is a NUL-terminated file name. On failure writes the reason (without
  // the path) into reason_buf (reason_size bytes, may be null) and returns false. Never throws.
  bool read(const char* path, std::uint8_t* dst, std::size_t capacity, int* width, int* height,
            char* reason_buf, std::size_t reason_size);

  std::size_t arena_bytes() const;
  std::size_t arena_high_water_bytes() const;  // largest arena use of any read so far
  std::uint64_t heap_fallbacks() const;        // libpng requests that did not fit the arena

  struct State;  // implementation detail (arena, file buffer); public for the C callbacks

 private:
  std::unique_ptr<State> state_;
};

}  // namespace ums::hal
