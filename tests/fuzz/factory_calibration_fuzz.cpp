// The D455 factory calibration read over the HWM tunnel: a 1024-byte reply (the input, zero
// padded or cut) through hwm_parse_reply, its payload through parse_stereo_coefficients; and the
// input as a table by itself with its header CRC made to match, so the fuzzer reaches the values
// behind the checksum.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "hal/d455/factory_calibration.hpp"

namespace {

void parse_all_sizes(const std::uint8_t* table, std::size_t size) {
  static const int kSizes[3][2] = {{848, 480}, {1280, 720}, {7, 7}};
  for (const auto& wh : kSizes) {
    ums::d455::StereoFactoryCalibration calibration;
    std::string error;
    (void)ums::d455::parse_stereo_coefficients(table, size, wh[0], wh[1], &calibration, &error);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::uint8_t reply[ums::d455::kHwmBufferBytes] = {};
  std::memcpy(reply, data, std::min(size, sizeof(reply)));
  const std::uint8_t* payload = nullptr;
  std::size_t payload_size = 0;
  std::string error;
  if (ums::d455::hwm_parse_reply(reply, ums::d455::kHwmGetIntCal, &payload, &payload_size, &error) ==
      ums::Status::kOk) {
    const std::vector<std::uint8_t> exact(payload, payload + payload_size);  // exact size for ASan
    parse_all_sizes(exact.data(), exact.size());
  }
  std::vector<std::uint8_t> table(data, data + size);
  if (table.size() >= 16) {
    std::uint32_t table_size = 0;
    std::memcpy(&table_size, table.data() + 4, 4);
    if (table_size <= table.size() - 16) {
      const std::uint32_t crc = ums::d455::crc32(table.data() + 16, table_size);
      std::memcpy(table.data() + 12, &crc, 4);
    }
  }
  parse_all_sizes(table.data(), table.size());
  return 0;
}
