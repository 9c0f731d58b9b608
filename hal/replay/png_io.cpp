#include "hal/replay/png_io.hpp"

#include <fcntl.h>
#include <png.h>
#include <unistd.h>

#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace ums::hal {

// libpng allocates its structs, row buffers and zlib's inflate state on every decode. Routing
// those requests to a bump arena that is rewound before each read() makes the decode
// heap-free; a plain read() on a file descriptor with our own buffer replaces stdio (fopen
// allocates its FILE and buffer).
struct PngGrayReader::State {
  static constexpr std::size_t kAlign = alignof(std::max_align_t);
  static constexpr std::size_t kFileBufferBytes = 64 * 1024;

  std::unique_ptr<unsigned char[]> arena;
  std::size_t arena_size = 0;
  std::size_t arena_used = 0;
  std::size_t high_water = 0;
  std::uint64_t fallbacks = 0;

  std::unique_ptr<unsigned char[]> file_buffer;
  std::size_t buffer_pos = 0;
  std::size_t buffer_len = 0;
  int fd = -1;

  char reason[256] = {};

  bool in_arena(const void* p) const {
    const auto* c = static_cast<const unsigned char*>(p);
    return c >= arena.get() && c < arena.get() + arena_size;
  }
};

namespace {

using State = PngGrayReader::State;

png_voidp arena_malloc(png_structp png, png_alloc_size_t size) {
  auto* s = static_cast<State*>(png_get_mem_ptr(png));
  const std::size_t aligned = (size + State::kAlign - 1) / State::kAlign * State::kAlign;
  if (aligned <= s->arena_size - s->arena_used) {
    void* p = s->arena.get() + s->arena_used;
    s->arena_used += aligned;
    if (s->arena_used > s->high_water) s->high_water = s->arena_used;
    return p;
  }
  ++s->fallbacks;
  return std::malloc(size);
}

void arena_free(png_structp png, png_voidp ptr) {
  auto* s = static_cast<State*>(png_get_mem_ptr(png));
  // Arena blocks are released all at once when the next read rewinds the arena.
  if (ptr != nullptr && !s->in_arena(ptr)) std::free(ptr);
}

void on_png_error(png_structp png, png_const_charp message) {
  auto* s = static_cast<State*>(png_get_error_ptr(png));
  std::snprintf(s->reason, sizeof(s->reason), "%s", message);
  png_longjmp(png, 1);
}

void on_png_warning(png_structp, png_const_charp) {
  // Warnings (unknown chunks, bad gamma, ...) do not stop a decode; nothing to report per frame.
}

void read_from_fd(png_structp png, png_bytep out, png_size_t length) {
  auto* s = static_cast<State*>(png_get_io_ptr(png));
  while (length > 0) {
    if (s->buffer_pos == s->buffer_len) {
      ssize_t n;
      do {
        n = ::read(s->fd, s->file_buffer.get(), State::kFileBufferBytes);
      } while (n < 0 && errno == EINTR);
      if (n < 0) png_error(png, "read error");
      if (n == 0) png_error(png, "truncated file (unexpected end of data)");
      s->buffer_pos = 0;
      s->buffer_len = static_cast<std::size_t>(n);
    }
    std::size_t chunk = s->buffer_len - s->buffer_pos;
    if (chunk > length) chunk = length;
    std::memcpy(out, s->file_buffer.get() + s->buffer_pos, chunk);
    s->buffer_pos += chunk;
    out += chunk;
    length -= chunk;
  }
}

// Kept free of objects with destructors: png_error longjmps back into this frame.
bool decode(State& s, std::uint8_t* dst, std::size_t capacity, int* width, int* height) {
  png_structp png = png_create_read_struct_2(PNG_LIBPNG_VER_STRING, &s, on_png_error,
                                             on_png_warning, &s, arena_malloc, arena_free);
  if (png == nullptr) {
    std::snprintf(s.reason, sizeof(s.reason), "cannot create the PNG decoder (out of memory)");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    std::snprintf(s.reason, sizeof(s.reason), "cannot create the PNG decoder (out of memory)");
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  png_set_read_fn(png, &s, read_from_fd);
  png_read_info(png, info);

  png_uint_32 w = 0, h = 0;
  int bit_depth = 0, color_type = 0, interlace = 0;
  png_get_IHDR(png, info, &w, &h, &bit_depth, &color_type, &interlace, nullptr, nullptr);
  if (static_cast<std::size_t>(w) * h > capacity) {
    std::snprintf(s.reason, sizeof(s.reason),
                  "image %ux%u does not fit the %zu-byte buffer", static_cast<unsigned>(w),
                  static_cast<unsigned>(h), capacity);
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (color_type == PNG_COLOR_TYPE_GRAY && bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (bit_depth == 16) png_set_scale_16(png);
  if ((color_type & PNG_COLOR_MASK_ALPHA) != 0) png_set_strip_alpha(png);
  if ((color_type & PNG_COLOR_MASK_COLOR) != 0) {
    // error_action 1: convert silently; default (Rec. 709) weights.
    png_set_rgb_to_gray_fixed(png, 1, -1, -1);
  }
  const int passes = png_set_interlace_handling(png);
  png_read_update_info(png, info);
  if (png_get_rowbytes(png, info) != w) {
    std::snprintf(s.reason, sizeof(s.reason), "cannot convert this PNG to 8-bit grey");
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  for (int pass = 0; pass < passes; ++pass) {
    for (png_uint_32 y = 0; y < h; ++y) png_read_row(png, dst + static_cast<std::size_t>(y) * w, nullptr);
  }
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  *width = static_cast<int>(w);
  *height = static_cast<int>(h);
  return true;
}

}  // namespace

PngGrayReader::PngGrayReader(std::size_t arena_bytes) : state_(new State) {
  state_->arena.reset(new unsigned char[arena_bytes]);
  state_->arena_size = arena_bytes;
  state_->file_buffer.reset(new unsigned char[State::kFileBufferBytes]);
}

PngGrayReader::~PngGrayReader() = default;

std::size_t PngGrayReader::arena_bytes() const { return state_->arena_size; }
std::size_t PngGrayReader::arena_high_water_bytes() const { return state_->high_water; }
std::uint64_t PngGrayReader::heap_fallbacks() const { return state_->fallbacks; }

bool PngGrayReader::read(const char* path, std::uint8_t* dst, std::size_t capacity, int* width,
                         int* height, char* reason_buf, std::size_t reason_size) {
  State& s = *state_;
  s.arena_used = 0;
  s.buffer_pos = 0;
  s.buffer_len = 0;
  s.reason[0] = '\0';
  bool ok = false;
  s.fd = ::open(path, O_RDONLY | O_CLOEXEC);
  if (s.fd < 0) {
    std::snprintf(s.reason, sizeof(s.reason), "cannot open (%s)", std::strerror(errno));
  } else {
    ok = decode(s, dst, capacity, width, height);
    ::close(s.fd);
    s.fd = -1;
  }
  if (!ok && reason_buf != nullptr && reason_size > 0) {
    std::snprintf(reason_buf, reason_size, "%s", s.reason[0] != '\0' ? s.reason : "unknown PNG error");
  }
  return ok;
}

bool read_png_size(const char* path, int* width, int* height) {
  const int fd = ::open(path, O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  unsigned char header[24];
  std::size_t got = 0;
  while (got < sizeof(header)) {
    const ssize_t n = ::read(fd, header + got, sizeof(header) - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    got += static_cast<std::size_t>(n);
  }
  ::close(fd);
  // Signature, then the first chunk must be IHDR: length(4) "IHDR" width(4) height(4), big-endian.
  if (got < sizeof(header) || png_sig_cmp(header, 0, 8) != 0 || std::memcmp(header + 12, "IHDR", 4) != 0) {
    return false;
  }
  auto be32 = [&](int at) {
    return (static_cast<std::uint32_t>(header[at]) << 24) | (static_cast<std::uint32_t>(header[at + 1]) << 16) |
           (static_cast<std::uint32_t>(header[at + 2]) << 8) | static_cast<std::uint32_t>(header[at + 3]);
  };
  const std::uint32_t w = be32(16), h = be32(20);
  if (w == 0 || h == 0 || w > 0x7fffffffu || h > 0x7fffffffu) return false;
  *width = static_cast<int>(w);
  *height = static_cast<int>(h);
  return true;
}

bool read_png_gray8(const std::string& path, std::uint8_t* dst, std::size_t capacity, int* width,
                    int* height, std::string* error) {
  PngGrayReader reader;
  char reason[256];
  if (reader.read(path.c_str(), dst, capacity, width, height, reason, sizeof(reason))) return true;
  if (error != nullptr) *error = path + ": " + reason;
  return false;
}

namespace {

struct WriteContext {
  char reason[256] = {};
};

void on_write_error(png_structp png, png_const_charp message) {
  auto* c = static_cast<WriteContext*>(png_get_error_ptr(png));
  std::snprintf(c->reason, sizeof(c->reason), "%s", message);
  png_longjmp(png, 1);
}

// Kept free of objects with destructors: png_error longjmps back into this frame.
bool encode(std::FILE* file, const ImageView& image, WriteContext& context) {
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, &context, on_write_error, on_png_warning);
  if (png == nullptr) {
    std::snprintf(context.reason, sizeof(context.reason), "cannot create the PNG encoder");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_write_struct(&png, nullptr);
    std::snprintf(context.reason, sizeof(context.reason), "cannot create the PNG encoder");
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_init_io(png, file);
  // Level 3 keeps files close to EuRoC's sizes while writing several times faster than the default
  // 6 (the simulator and the recorder write thousands of frames).
  png_set_compression_level(png, 3);
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.width),
               static_cast<png_uint_32>(image.height), 8, PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < image.height; ++y) png_write_row(png, image.row(y));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

}  // namespace

bool write_png_gray8(const std::string& path, const ImageView& image, std::string* error) {
  auto fail = [&](const std::string& reason) {
    if (error != nullptr) *error = path + ": " + reason;
    return false;
  };
  if (!image.valid()) return fail("invalid image view (null data, empty size or stride < width)");
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr) return fail(std::string("cannot create (") + std::strerror(errno) + ")");
  WriteContext context;
  const bool encoded = encode(file, image, context);
  const bool closed = std::fclose(file) == 0;
  if (!encoded) return fail(context.reason[0] != '\0' ? context.reason : "unknown PNG error");
  if (!closed) return fail(std::string("write failed (") + std::strerror(errno) + ")");
  return true;
}

}  // namespace ums::hal
