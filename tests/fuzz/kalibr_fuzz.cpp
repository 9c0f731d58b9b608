// Kalibr output: camchain-imucam.yaml and imu.yaml, given as two files separated by a "--" line
// (without a separator the imu.yaml is left out, which read_kalibr allows).
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "hal/d455/kalibr_reader.hpp"
#include "tests/fuzz/fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string parts[2];
  const std::size_t n = ums::fuzz::split_parts(data, size, parts, 2);
  const std::string camchain = ums::fuzz::write_file("camchain-imucam.yaml", parts[0]);
  const std::string imu = n > 1 ? ums::fuzz::write_file("imu.yaml", parts[1]) : std::string();
  try {
    (void)ums::d455::read_kalibr(camchain, imu);
  } catch (const std::exception&) {
  }
  return 0;
}
