// PNG decoding as replay does it: the arena-backed PngGrayReader into a buffer of the largest
// frame the product accepts, and the header-only size probe.
#include <cstddef>
#include <cstdint>
#include <memory>

#include "core/common/capacity.hpp"
#include "hal/replay/png_io.hpp"
#include "tests/fuzz/fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static constexpr std::size_t kCapacity =
      static_cast<std::size_t>(ums::capacity::kMaxImageWidth) * ums::capacity::kMaxImageHeight;
  static ums::hal::PngGrayReader reader;  // reused like replay's: arena state across reads is exercised
  static const std::unique_ptr<std::uint8_t[]> image(new std::uint8_t[kCapacity]);
  const std::string path = ums::fuzz::write_file("image.png", data, size);
  int width = 0, height = 0;
  (void)ums::hal::read_png_size(path.c_str(), &width, &height);
  char reason[256];
  (void)reader.read(path.c_str(), image.get(), kCapacity, &width, &height, reason, sizeof(reason));
  return 0;
}
