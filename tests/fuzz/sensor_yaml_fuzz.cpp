// EuRoC sensor.yaml: the same bytes read as a camera and as an IMU file (the two readers share
// the YAML layer, and a user may point either at any file).
#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include "hal/replay/euroc_sensor_yaml.hpp"
#include "tests/fuzz/fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = ums::fuzz::write_file("sensor.yaml", data, size);
  try {
    (void)ums::hal::read_euroc_camera_yaml(path);
  } catch (const std::exception&) {
  }
  try {
    (void)ums::hal::read_euroc_imu_yaml(path);
  } catch (const std::exception&) {
  }
  return 0;
}
