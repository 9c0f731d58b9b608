// IIO scan records: the input's first part (up to a "--" line) lists channels as
// "<scan index> <type>" lines, as iio_imu.cpp reads them from sysfs (in_*_index, in_*_type); the
// rest is the buffer read from /dev/iio:deviceN, decoded record by record like the IMU does.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "hal/d455/iio_scan.hpp"
#include "tests/fuzz/fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string parts[2];
  const std::size_t n = ums::fuzz::split_parts(data, size, parts, 2);
  ums::d455::IioScanLayout layout;
  std::istringstream lines(parts[0]);
  std::string line;
  while (std::getline(lines, line)) {
    const std::size_t space = line.find(' ');
    if (space == std::string::npos) continue;
    ums::d455::IioChannelType type;
    if (!ums::d455::parse_iio_type(line.substr(space + 1), &type)) continue;
    (void)layout.add(std::atoi(line.substr(0, space).c_str()), type);
  }
  if (n < 2 || layout.size() == 0 || !layout.finalize() || layout.record_bytes() <= 0) return 0;
  const std::vector<std::uint8_t> buffer(parts[1].begin(), parts[1].end());
  const std::size_t record = static_cast<std::size_t>(layout.record_bytes());
  for (std::size_t at = 0; at + record <= buffer.size(); at += record) {
    for (std::size_t slot = 0; slot < layout.size(); ++slot) {
      (void)ums::d455::iio_extract(buffer.data() + at, layout.at(static_cast<int>(slot)));
    }
  }
  return 0;
}
