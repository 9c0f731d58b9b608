#include "hal/replay/euroc_writer.hpp"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <csignal>
#include <cstdio>
#include <fstream>
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

namespace {

// What a writer that ran out of room reported (from a child process, over a pipe).
struct FullDiskRun {
  int status = -1;
  std::uint64_t frames = 0, imu = 0;
  char error[256] = {};
};

// Writes 20 Hz frames (40x30, or 400x300 noise from big_frame on: about 120 KB of PNG) with
// 400 Hz IMU into dir, in a child process whose files may not grow beyond limit_bytes (a full
// disk as the writer sees it: the write fails with EFBIG instead of ENOSPC), until a write fails.
FullDiskRun write_until_full(const std::string& dir, long limit_bytes, int big_frame) {
  int fds[2];
  REQUIRE(::pipe(fds) == 0);
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    ::close(fds[0]);
    std::signal(SIGXFSZ, SIG_IGN);
    const struct rlimit lim{static_cast<rlim_t>(limit_bytes), static_cast<rlim_t>(limit_bytes)};
    ::setrlimit(RLIMIT_FSIZE, &lim);
    FullDiskRun r;
    ums::hal::EurocWriter writer;
    writer.open(dir, test_rig());
    std::vector<std::uint8_t> px[2] = {std::vector<std::uint8_t>(400 * 300), std::vector<std::uint8_t>(400 * 300)};
    std::uint32_t noise = 12345;
    ums::Status st = ums::Status::kOk;
    for (int f = 0; f < 2000 && st == ums::Status::kOk; ++f) {
      const std::int64_t t0 = 1'000'000'000LL + f * 50'000'000LL;
      for (int k = 0; k < 20 && st == ums::Status::kOk; ++k) {
        ImuSample s;
        s.t_ns = t0 + k * 2'500'000LL;
        s.gyro_rad_s = Eigen::Vector3d(0.1 * f, -0.2, 0.3 + k);
        s.accel_m_s2 = Eigen::Vector3d(0.4, 9.81, -0.01 * k);
        st = writer.write_imu(s);
      }
      if (st != ums::Status::kOk) break;
      const int w = f >= big_frame ? 400 : 40, h = f >= big_frame ? 300 : 30;
      for (auto& p : px)
        for (auto& v : p) v = static_cast<std::uint8_t>((noise = noise * 1664525u + 1013904223u) >> 24);
      StereoFrame frame;
      frame.t_ns = t0 + 50'000'000LL - 1;
      frame.left = ums::ImageView{px[0].data(), w, h, w};
      frame.right = ums::ImageView{px[1].data(), w, h, w};
      st = writer.write_stereo(frame);
    }
    try {
      writer.close();
    } catch (const std::exception&) {
    }
    r.status = static_cast<int>(writer.status());
    r.frames = writer.frames_written();
    r.imu = writer.imu_written();
    std::snprintf(r.error, sizeof r.error, "%s", writer.error().c_str());
    (void)!::write(fds[1], &r, sizeof r);
    ::_exit(0);
  }
  ::close(fds[1]);
  FullDiskRun r;
  REQUIRE(::read(fds[0], &r, sizeof r) == static_cast<ssize_t>(sizeof r));
  ::close(fds[0]);
  int wstatus = 0;
  ::waitpid(pid, &wstatus, 0);
  REQUIRE(WIFEXITED(wstatus));
  return r;
}

// Every committed frame and IMU row reads back; nothing more.
void check_replays(const std::string& dir, const FullDiskRun& r) {
  EurocReader reader;
  reader.open(dir);
  std::uint64_t frames = 0, imu = 0;
  ImuSample s;
  StereoFrame f;
  for (;;) {
    const auto e = reader.next(&s, &f);
    if (e == EurocReader::Event::kEnd) break;
    if (e == EurocReader::Event::kImu) ++imu;
    if (e == EurocReader::Event::kStereo) {
      ++frames;
      CHECK(f.right.valid());
    }
  }
  CHECK(frames == r.frames);
  CHECK(imu == r.imu);
}

}  // namespace

// A full disk mid-recording: a clear error naming the file, and the folder is a dataset of
// everything the writer had committed (whole rows, whole PNG pairs), which the reader replays.
TEST_CASE("EuRoC writer on a full disk keeps a valid dataset of what it committed", "[euroc][writer]") {
  SECTION("the IMU file fills first") {
    const std::string dir = ums::test::make_temp_dir("euroc_writer_full_imu");
    const FullDiskRun r = write_until_full(dir, 64 * 1024, 1 << 30);
    INFO(r.error);
    CHECK(r.status == static_cast<int>(ums::Status::kIoError));
    CHECK(std::string(r.error).find("imu0/data.csv: write failed (File too large)") != std::string::npos);
    CHECK(std::string(r.error).find("the dataset keeps the " + std::to_string(r.frames) + " frames") != std::string::npos);
    CHECK(r.frames >= 20);  // about 480 IMU rows fit in 64 KB
    CHECK(r.imu == 20 * r.frames);
    check_replays(dir, r);
  }
  SECTION("a PNG does not fit") {
    const std::string dir = ums::test::make_temp_dir("euroc_writer_full_png");
    const FullDiskRun r = write_until_full(dir, 64 * 1024, 5);
    INFO(r.error);
    CHECK(r.status == static_cast<int>(ums::Status::kIoError));
    CHECK(r.frames == 5);
    CHECK(r.imu == 100);
    // The frame that did not fit left no file behind.
    CHECK_FALSE(std::ifstream(dir + "/mav0/cam0/data/1299999999.png").good());
    CHECK(std::ifstream(dir + "/mav0/cam0/data/1249999999.png").good());
    check_replays(dir, r);
  }
}
