#include "hal/d455/factory_calibration.hpp"

#include <catch2/catch.hpp>

#include <linux/videodev2.h>

#include <cstring>
#include <vector>

#include "hal/d455/nominal_calibration.hpp"
#include "tests/hal/d455/fake_kernel.hpp"

using namespace ums::d455;
using ums::Status;

namespace {
template <typename T>
void put(std::vector<std::uint8_t>* b, std::size_t at, T v) {
  std::memcpy(b->data() + at, &v, sizeof(T));
}

// A 576-byte coefficients table with one unit's values (notes §5.2, §5.4): baseline -94.9609 mm,
// 848x480 entry (index 3) fx = fy = 429.278, ppx 429.302, ppy 242.071.
std::vector<std::uint8_t> coefficients_table() {
  std::vector<std::uint8_t> t(576, 0);
  put<std::uint16_t>(&t, 0, 0x0200);
  put<std::uint16_t>(&t, 2, 25);
  put<std::uint32_t>(&t, 4, 576 - 16);
  put<float>(&t, 160, -94.9609f);
  put<std::uint32_t>(&t, 164, 1);
  const float e3[4] = {429.278f, 429.278f, 429.302f, 242.071f};
  std::memcpy(t.data() + 256 + 16 * 3, e3, sizeof e3);
  const float e2[4] = {388.78f, 388.78f, 324.802f, 241.876f};
  std::memcpy(t.data() + 256 + 16 * 2, e2, sizeof e2);
  put<std::uint32_t>(&t, 12, crc32(t.data() + 16, 576 - 16));
  return t;
}

std::vector<std::uint8_t> reply_with(const std::vector<std::uint8_t>& payload, std::int32_t echo = 0x15) {
  std::vector<std::uint8_t> r(1024, 0);
  put<std::int32_t>(&r, 0, echo);
  // An empty payload's data() may be null, and memcpy from null is undefined even for 0 bytes (UBSan).
  if (!payload.empty()) std::memcpy(r.data() + 4, payload.data(), payload.size());
  put<std::uint32_t>(&r, 1020, static_cast<std::uint32_t>(4 + payload.size()));
  return r;
}
}  // namespace

TEST_CASE("CRC-32 is the zlib one (check value of \"123456789\")", "[d455][factory]") {
  const char* text = "123456789";
  CHECK(crc32(reinterpret_cast<const std::uint8_t*>(text), 9) == 0xCBF43926u);
}

TEST_CASE("GETINTCAL 25 over the XU tunnel yields the rectified intrinsics and a 94.96 mm baseline", "[d455][factory]") {
  test::FakeKernel kernel;
  kernel.add_video("/fake/video2", {V4L2_PIX_FMT_Y8I});
  kernel.hwm_reply = reply_with(coefficients_table());
  StereoFactoryCalibration f;
  std::string error;
  REQUIRE(read_stereo_factory_calibration(kernel, "/fake/video2", 848, 480, &f, &error) == Status::kOk);
  // Request bytes: length 20, magic AB CD, opcode 0x15, p1 = 25, zero padded to 1024.
  REQUIRE(kernel.hwm_request.size() == 1024);
  CHECK(kernel.hwm_request[0] == 20);
  CHECK(kernel.hwm_request[2] == 0xAB);
  CHECK(kernel.hwm_request[3] == 0xCD);
  CHECK(kernel.hwm_request[4] == 0x15);
  CHECK(kernel.hwm_request[8] == 25);
  CHECK(f.fx == Approx(429.278));
  CHECK(f.cx == Approx(429.302));
  CHECK(f.cy == Approx(242.071));
  CHECK(f.baseline_m == Approx(0.0949609));
  CHECK(kernel.open_fds() == 0);
  REQUIRE(read_stereo_factory_calibration(kernel, "/fake/video2", 640, 480, &f, &error) == Status::kOk);
  CHECK(f.fx == Approx(388.78));

  ums::RigCalibration rig = d455_nominal_calibration(848, 480, 30.0, 400.0);
  REQUIRE(read_stereo_factory_calibration(kernel, "/fake/video2", 848, 480, &f, &error) == Status::kOk);
  apply_stereo_factory_calibration(f, &rig);
  CHECK((rig.cam[1].T_b_c.translation() - rig.cam[0].T_b_c.translation()).x() == Approx(0.0949609));
  CHECK(rig.cam[1].fx == Approx(429.278));
}

TEST_CASE("Factory read refuses corrupted tables, device errors and unknown resolutions", "[d455][factory]") {
  test::FakeKernel kernel;
  kernel.add_video("/fake/video2", {V4L2_PIX_FMT_Y8I});
  StereoFactoryCalibration f;
  std::string error;
  auto table = coefficients_table();
  table[300] ^= 0x01;  // one flipped bit
  kernel.hwm_reply = reply_with(table);
  CHECK(read_stereo_factory_calibration(kernel, "/fake/video2", 848, 480, &f, &error) == Status::kInvalidInput);
  CHECK(error.find("CRC") != std::string::npos);
  kernel.hwm_reply = reply_with({}, -21);  // NO_DATA_TO_RETURN
  CHECK(read_stereo_factory_calibration(kernel, "/fake/video2", 848, 480, &f, &error) == Status::kIoError);
  CHECK(error.find("-21") != std::string::npos);
  kernel.hwm_reply = reply_with(coefficients_table());
  CHECK(read_stereo_factory_calibration(kernel, "/fake/video2", 800, 600, &f, &error) == Status::kUnsupported);
  auto short_table = coefficients_table();
  short_table.resize(400);
  kernel.hwm_reply = reply_with(short_table);
  CHECK(read_stereo_factory_calibration(kernel, "/fake/video2", 848, 480, &f, &error) == Status::kInvalidInput);
  kernel.refuse_xu = true;
  CHECK(read_stereo_factory_calibration(kernel, "/fake/video2", 848, 480, &f, &error) == Status::kIoError);
}
