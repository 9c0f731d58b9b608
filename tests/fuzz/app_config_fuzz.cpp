// The program config (VINS-Fusion keys) with its camodocal camN_calib companions: the input is up
// to three files separated by a "--" line: config.yaml, cam0.yaml, cam1.yaml (the seeds name
// them as cam0_calib / cam1_calib, relative to the config as VINS-Fusion does).
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "board/config/app_config.hpp"
#include "hal/replay/euroc_sensor_yaml.hpp"
#include "tests/fuzz/fuzz_file.hpp"

namespace {

// The defaults a replay passes: the dataset's sensor.yaml calibration (the micro dataset's).
ums::RigCalibration dataset_rig() {
  const std::string dir = UMS_FUZZ_FIXTURES "/euroc/";
  ums::RigCalibration rig;
  rig.cam[0] = ums::hal::read_euroc_camera_yaml(dir + "cam0.yaml");
  rig.cam[1] = ums::hal::read_euroc_camera_yaml(dir + "cam1.yaml");
  rig.imu = ums::hal::read_euroc_imu_yaml(dir + "imu0.yaml");
  return rig;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const ums::RigCalibration rig = dataset_rig();
  static const char* const kNames[3] = {"config.yaml", "cam0.yaml", "cam1.yaml"};
  std::string parts[3];
  const std::size_t n = ums::fuzz::split_parts(data, size, parts, 3);
  for (std::size_t i = 0; i < 3; ++i) ums::fuzz::write_file(kNames[i], i < n ? parts[i] : std::string());
  std::vector<std::string> warnings;
  try {
    const ums::AppConfig config = ums::load_config(ums::fuzz::scratch_dir() + "/config.yaml",
                                                   rig, &warnings);
    config.validate();
  } catch (const std::exception&) {
  }
  return 0;
}
