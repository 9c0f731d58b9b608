// One buffer of the UVC metadata node (kernel block, UVC header, D4XX blocks), exactly the bytes
// the driver reports as used.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "hal/d455/uvc_metadata.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::vector<std::uint8_t> buffer(data, data + size);  // an exact-size heap copy for ASan
  ums::d455::UvcFrameMeta meta;
  (void)ums::d455::parse_uvc_metadata(buffer.data(), buffer.size(), &meta);
  return 0;
}
