// EuRoC state_groundtruth_estimate0/data.csv through the hal reader (replay's ground truth).
#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include "hal/replay/euroc_groundtruth.hpp"
#include "tests/fuzz/fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = ums::fuzz::write_file("data.csv", data, size);
  ums::hal::EurocGroundtruthReader reader;
  try {
    reader.open(path);
  } catch (const std::exception&) {
    return 0;
  }
  ums::hal::GroundTruthState state;
  while (reader.next(&state) == ums::hal::CsvReader::Result::kRow) {
  }
  return 0;
}
