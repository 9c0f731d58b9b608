// EuRoC data.csv rows of cam0, cam1 and imu0 through the real dataset reader (EurocReader::open
// validates every row, pairs the cameras, then next() streams). The input is up to three files
// separated by a "--" line: cam0/data.csv, cam1/data.csv, imu0/data.csv; a missing one gets a
// valid default so the others still reach the pairing and streaming code. The sensor.yaml files
// are fixed (tests/fuzz/fixtures/euroc, the micro dataset's), and 1000.png exists in both camera
// folders (a flat 752x480 frame) so the seeds' pairs are decoded and streamed.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "core/common/imu_sample.hpp"
#include "core/common/stereo_frame.hpp"
#include "hal/replay/euroc_reader.hpp"
#include "tests/fuzz/fuzz_file.hpp"

namespace {

const char* const kCsvPaths[3] = {"mav0/cam0/data.csv", "mav0/cam1/data.csv", "mav0/imu0/data.csv"};
const char* const kDefaults[3] = {"1000,1000.png\n", "1000,1000.png\n",
                                  "900,0,0,0,0,0,9.81\n1100,0,0,0,0,0,9.81\n"};

void make_dataset() {
  const std::string fixtures = UMS_FUZZ_FIXTURES "/euroc/";
  for (const char* sensor : {"cam0", "cam1", "imu0"}) {
    ums::fuzz::copy_file(fixtures + sensor + ".yaml", std::string("mav0/") + sensor + "/sensor.yaml");
  }
  ums::fuzz::copy_file(fixtures + "frame.png", "mav0/cam0/data/1000.png");
  ums::fuzz::copy_file(fixtures + "frame.png", "mav0/cam1/data/1000.png");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const bool made = (make_dataset(), true);
  (void)made;
  std::string parts[3];
  const std::size_t n = ums::fuzz::split_parts(data, size, parts, 3);
  for (std::size_t i = 0; i < 3; ++i) ums::fuzz::write_file(kCsvPaths[i], i < n ? parts[i] : kDefaults[i]);
  ums::hal::EurocReader reader;
  try {
    reader.open(ums::fuzz::scratch_dir());
  } catch (const std::exception&) {
    return 0;  // a clear refusal is the expected outcome for most inputs
  }
  ums::ImuSample imu;
  ums::StereoFrame frame;
  while (reader.next(&imu, &frame) != ums::hal::EurocReader::Event::kEnd) {
  }
  return 0;
}
