// `umsvins eval` inputs: an estimate or ground-truth trajectory in any of the formats the reader
// detects by content (TUM, EuRoC ground truth, the shared *_GT.txt), and the cam0 sensor.yaml
// whose T_BS eval reads with its own small reader (--cam0-sensor-yaml).
#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include "profiling/eval/trajectory.hpp"
#include "tests/fuzz/fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = ums::fuzz::write_file("trajectory.txt", data, size);
  try {
    (void)ums::eval::read_trajectory(path, ums::eval::TrajectoryFormat::kAuto);
  } catch (const std::exception&) {
  }
  try {
    (void)ums::eval::read_T_BS(path);
  } catch (const std::exception&) {
  }
  return 0;
}
