#include "hal/replay/euroc_writer.hpp"

#include <catch2/catch.hpp>
#include <vector>

#include "hal/replay/euroc_groundtruth.hpp"
#include "hal/replay/euroc_reader.hpp"
#include "tests/common/test_paths.hpp"

using ums::ImuSample;
using ums::StereoFrame;
using ums::hal::EurocReader;

namespace {

ums::RigCalibration test_rig() {
  ums::RigCalibration rig;
  for (int side = 0; side < 2; ++side) {
    auto& cam = rig.cam[side];
    cam.width = 40;
    cam.height = 30;
    cam.rate_hz = 20;
    cam.fx = 35.123456789012345 + side;
    cam.fy = 34.9 - side;
    cam.cx = 19.7;
    cam.cy = 15.1;
    cam.distortion = {-0.28, 0.07, 1.9e-4, -1.7e-5};
    cam.T_b_c.linear() = Eigen::AngleAxisd(0.3 + side, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    cam.T_b_c.translation() = Eigen::Vector3d(-0.02, -0.06 + 0.11 * side, 0.01);
  }
  rig.cam[1].model = ums::CameraModel::kPinholeEquidistant;
  rig.imu.rate_hz = 400;
  rig.imu.gyro_noise_density = 1.1e-4;
  rig.imu.gyro_random_walk = 2.2e-6;
  rig.imu.accel_noise_density = 3.3e-3;
  rig.imu.accel_random_walk = 4.4e-4;
  return rig;
}

std::uint8_t pixel(int frame, int side, int x, int y) {
  return static_cast<std::uint8_t>((x * 13 + y * 7 + frame * 31 + side * 101) & 0xff);
}

}  // namespace

TEST_CASE("EuRoC writer round trip: timestamps, calibration, IMU values and pixels", "[euroc][writer]") {
  const std::string dir = ums::test::make_temp_dir("euroc_writer_round_trip");
  const ums::RigCalibration rig = test_rig();
  ums::hal::EurocWriter writer;
  writer.open(dir, rig, true);
  const std::int64_t t0 = 1403715273262142976;
  std::vector<ImuSample> imu_written;
  for (int i = 0; i < 50; ++i) {
    ImuSample s;
    s.t_ns = t0 + i * 2500000 + (i % 3);  // 400 Hz with odd nanoseconds
    s.gyro_rad_s = Eigen::Vector3d(0.1 * i, -1.0 / 3.0, 1e-17 * i);
    s.accel_m_s2 = Eigen::Vector3d(9.81, 0.2 / 7.0, -3.6938381666666662);
    REQUIRE(writer.write_imu(s) == ums::Status::kOk);
    imu_written.push_back(s);
  }
  std::vector<std::uint8_t> left(40 * 30), right(40 * 30);
  for (int f = 0; f < 3; ++f) {
    for (int y = 0; y < 30; ++y)
      for (int x = 0; x < 40; ++x) {
        left[y * 40 + x] = pixel(f, 0, x, y);
        right[y * 40 + x] = pixel(f, 1, x, y);
      }
    StereoFrame frame;
    frame.t_ns = t0 + f * 50000000 + 7;
    frame.left = ums::ImageView{left.data(), 40, 30, 40};
    frame.right = ums::ImageView{right.data(), 40, 30, 40};
    REQUIRE(writer.write_stereo(frame) == ums::Status::kOk);
    ums::hal::GroundTruthState gt;
    gt.t_ns = frame.t_ns;
    gt.p_w_b = Eigen::Vector3d(f, 2.0 / 3.0, -1);
    gt.q_w_b = Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * f, Eigen::Vector3d::UnitZ()));
    gt.v_w_b = Eigen::Vector3d(0.5, 0, 0);
    gt.gyro_bias_rad_s = Eigen::Vector3d(1e-3, 2e-3, 3e-3);
    gt.accel_bias_m_s2 = Eigen::Vector3d(-0.02, 0.01, 0.07);
    REQUIRE(writer.write_groundtruth(gt) == ums::Status::kOk);
  }
  // Rejected inputs leave the files intact.
  StereoFrame late;
  late.t_ns = t0;
  late.left = ums::ImageView{left.data(), 40, 30, 40};
  CHECK(writer.write_stereo(late) == ums::Status::kInvalidInput);
  CHECK(writer.frames_written() == 3);
  CHECK(writer.imu_written() == 50);
  CHECK_THROWS_WITH(writer.close(), Catch::Contains("not after"));

  EurocReader reader;
  ums::hal::EurocReaderOptions options;
  options.imu_after_last_frame = true;
  reader.open(dir, options);
  CHECK(reader.has_groundtruth());
  const ums::RigCalibration& got = reader.calibration();
  for (int side = 0; side < 2; ++side) {
    const auto& a = rig.cam[side];
    const auto& b = got.cam[side];
    CHECK(b.width == a.width);
    CHECK(b.height == a.height);
    CHECK(b.model == a.model);
    CHECK(b.rate_hz == a.rate_hz);
    CHECK(b.fx == a.fx);
    CHECK(b.fy == a.fy);
    CHECK(b.cx == a.cx);
    CHECK(b.cy == a.cy);
    CHECK(b.distortion == a.distortion);
    CHECK((b.T_b_c.matrix() - a.T_b_c.matrix()).cwiseAbs().maxCoeff() < 1e-15);
  }
  CHECK(got.imu.rate_hz == 400);
  CHECK(got.imu.gyro_noise_density == rig.imu.gyro_noise_density);
  CHECK(got.imu.gyro_random_walk == rig.imu.gyro_random_walk);
  CHECK(got.imu.accel_noise_density == rig.imu.accel_noise_density);
  CHECK(got.imu.accel_random_walk == rig.imu.accel_random_walk);

  ImuSample imu;
  StereoFrame frame;
  std::size_t imu_index = 0;
  int frame_index = 0;
  bool pixels_equal = true, imu_equal = true;
  for (;;) {
    const EurocReader::Event e = reader.next(&imu, &frame);
    if (e == EurocReader::Event::kEnd) break;
    if (e == EurocReader::Event::kImu) {
      const ImuSample& w = imu_written[imu_index++];
      imu_equal = imu_equal && imu.t_ns == w.t_ns && imu.gyro_rad_s == w.gyro_rad_s && imu.accel_m_s2 == w.accel_m_s2;
    } else {
      CHECK(frame.t_ns == t0 + frame_index * 50000000 + 7);
      for (int y = 0; y < 30; ++y)
        for (int x = 0; x < 40; ++x) {
          pixels_equal = pixels_equal && frame.left.row(y)[x] == pixel(frame_index, 0, x, y) &&
                         frame.right.row(y)[x] == pixel(frame_index, 1, x, y);
        }
      ++frame_index;
    }
  }
  CHECK(frame_index == 3);
  CHECK(imu_index == 50);
  CHECK(imu_equal);
  CHECK(pixels_equal);

  ums::hal::EurocGroundtruthReader gt_reader;
  gt_reader.open(reader.groundtruth_path());
  ums::hal::GroundTruthState gt;
  int rows = 0;
  ums::hal::CsvReader::Result r;
  while ((r = gt_reader.next(&gt)) == ums::hal::CsvReader::Result::kRow) {
    CHECK(gt.t_ns == t0 + rows * 50000000 + 7);
    CHECK(gt.p_w_b.y() == 2.0 / 3.0);
    CHECK(gt.q_w_b.angularDistance(Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * rows, Eigen::Vector3d::UnitZ()))) < 1e-12);
    CHECK(gt.accel_bias_m_s2.z() == 0.07);
    ++rows;
  }
  CHECK(r == ums::hal::CsvReader::Result::kEnd);
  CHECK(rows == 3);
}

TEST_CASE("EuRoC writer copies the real micro sequence through the sink interface", "[euroc][writer][real]") {
  EurocReader reader;
  ums::hal::EurocReaderOptions options;
  options.duration_s = 0.06;  // 2 pairs, enough to prove the copy (PNG encoding is slow under qemu)
  reader.open(ums::test::euroc_micro_dir(), options);
  const std::string dir = ums::test::make_temp_dir("euroc_writer_copy");
  ums::hal::EurocWriter writer;
  writer.open(dir, reader.calibration());
  REQUIRE(reader.push_all(writer) == ums::Status::kOk);
  writer.close();
  CHECK(writer.frames_written() == 2);
  CHECK(writer.imu_written() == 11);  // t0 .. t0 + 50 ms at 200 Hz

  EurocReader copy;
  copy.open(dir);
  CHECK(copy.summary().cam0_rows == 2);
  CHECK(copy.summary().imu_rows == 11);
  CHECK(copy.summary().cam0_first_t_ns == 1403715273262142976);
  CHECK(copy.calibration().cam[0].fx == 458.654);
  CHECK(copy.calibration().cam[1].T_b_c.translation().y() == 0.0453689425024);
}

TEST_CASE("EuRoC writer reports an unwritable folder", "[euroc][writer]") {
  ums::hal::EurocWriter writer;
  CHECK_THROWS_WITH(writer.open("/proc/ums_no_such/dir", test_rig()), Catch::Contains("/proc/ums_no_such/dir: cannot create folder"));
  StereoFrame frame;
  CHECK(writer.write_stereo(frame) == ums::Status::kInvalidInput);
}
