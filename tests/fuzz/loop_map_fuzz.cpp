// A map file (umsvins --load-map) loaded into a fresh loop closer, as LoopSession::load_map does.
// The header's vocabulary checksum and calibration hash are set to the closer's and the trailing
// CRC-32 made to match, so the fuzzer gets past the checks a random file fails at once and into
// the records. Closer: the built-in vocabulary and the micro dataset's calibration. A closer costs
// ~0.1 s to build, so one is kept while loads fail: load_map promises that a refused file changes
// nothing, so the same closer must take the next file as a fresh one (a broken promise shows up
// as a later good map being refused, or as a sanitizer report).
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <stdexcept>
#include <vector>

#include "core/loop/loop_closer.hpp"
#include "core/loop/vocabulary.hpp"
#include "hal/replay/euroc_sensor_yaml.hpp"

namespace {

ums::loop::Vocabulary builtin_vocabulary() {
  std::ifstream in(UMS_SOURCE_DIR "/board/host/vocabulary/sim_k10l4.voc", std::ios::binary);
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return ums::loop::Vocabulary::parse(bytes, "sim_k10l4.voc");
}

ums::RigCalibration dataset_rig() {
  const std::string dir = UMS_FUZZ_FIXTURES "/euroc/";
  ums::RigCalibration rig;
  rig.cam[0] = ums::hal::read_euroc_camera_yaml(dir + "cam0.yaml");
  rig.cam[1] = ums::hal::read_euroc_camera_yaml(dir + "cam1.yaml");
  rig.imu = ums::hal::read_euroc_imu_yaml(dir + "imu0.yaml");
  return rig;
}

void put_u32(std::vector<std::uint8_t>* bytes, std::size_t at, std::uint32_t v) {
  std::memcpy(bytes->data() + at, &v, 4);  // little endian, as the file
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const ums::loop::Vocabulary vocabulary = builtin_vocabulary();
  static const ums::RigCalibration rig = dataset_rig();
  static std::unique_ptr<ums::loop::LoopCloser> closer;
  if (!closer) closer = std::make_unique<ums::loop::LoopCloser>(ums::loop::LoopOptions{}, rig, vocabulary);
  std::vector<std::uint8_t> bytes(data, data + size);
  if (bytes.size() >= 36) {  // magic 8, version, vocabulary, calibration, counts, CRC
    put_u32(&bytes, 12, vocabulary.checksum());
    put_u32(&bytes, 16, closer->calibration_hash());
    put_u32(&bytes, bytes.size() - 4, ums::loop::crc32(bytes.data(), bytes.size() - 4));
  }
  try {
    closer->load_map(bytes, "fuzz.map");
    closer.reset();  // loaded: the next input needs a fresh closer
  } catch (const std::runtime_error&) {
  }
  return 0;
}
