#include "hal/d455/iio_imu.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>

#include "profiling/alloc_counter.hpp"
#include "tests/common/test_paths.hpp"
#include "tests/hal/d455/fake_kernel.hpp"

using namespace ums::d455;
using ums::Status;

namespace {
constexpr double kPi = 3.14159265358979323846;

std::string attr(const SysFs& fs, const std::string& path) {
  std::string s;
  fs.read_text(path, &s);
  return s;
}

void append(std::vector<std::uint8_t>* all, const std::vector<std::uint8_t>& r) {
  all->insert(all->end(), r.begin(), r.end());
}
}  // namespace

TEST_CASE("IIO gyro set-up writes trigger, scan enables, rate code, buffer length and enable", "[d455][iio]") {
  const std::string root = ums::test::make_temp_dir("d455_iio_setup");
  test::FakeKernel kernel;
  test::build_d455_tree(root, &kernel);
  SysFs fs(root);
  DeviceClockMap clock;
  ImuOptions o;  // gyro 400 Hz, accel 250 Hz
  IioSensor gyro(kernel, fs, ImuKind::kGyro, o, &clock);
  std::string error;
  const std::string dir = "/sys/bus/iio/devices/iio:device1";
  REQUIRE(gyro.open(dir, "/dev/iio:device1", &error) == Status::kOk);
  CHECK(attr(fs, dir + "/trigger/current_trigger") == "gyro_3d-dev1");
  CHECK(attr(fs, dir + "/scan_elements/in_anglvel_x_en") == "1");
  CHECK(attr(fs, dir + "/scan_elements/in_anglvel_z_en") == "1");
  CHECK(attr(fs, dir + "/scan_elements/in_timestamp_en") == "1");
  CHECK(attr(fs, dir + "/in_anglvel_sampling_frequency") == "4");  // hid_fps_translation code of 400 Hz
  CHECK(attr(fs, dir + "/in_anglvel_hysteresis") == "0.1");
  CHECK(attr(fs, dir + "/buffer/length") == "128");
  CHECK(attr(fs, dir + "/buffer/enable") == "1");
  CHECK(gyro.layout().record_bytes() == 24);
  // 16-bit firmware data: 0.1 deg/s per LSB.
  CHECK(gyro.lsb_to_si() == Approx(0.1 * kPi / 180.0).epsilon(1e-12));
  gyro.close();
  CHECK(attr(fs, dir + "/buffer/enable") == "0");
  CHECK(kernel.open_fds() == 0);

  IioSensor wrong(kernel, fs, ImuKind::kAccel, o, &clock);
  CHECK(wrong.open(dir, "/dev/iio:device1", &error) == Status::kUnsupported);  // gyro_3d is not accel
  CHECK(error.find("expected accel_3d") != std::string::npos);
}

TEST_CASE("IIO records decode to SI units in the body frame (diag(-1,1,-1)) on the device clock", "[d455][iio]") {
  const std::string root = ums::test::make_temp_dir("d455_iio_decode");
  test::FakeKernel kernel;
  test::build_d455_tree(root, &kernel, 32);  // FW >= 5.16: 32-bit, gyro 0.0001 deg/s per LSB
  SysFs fs(root);
  DeviceClockMap clock;
  ImuOptions o;
  IioSensor accel(kernel, fs, ImuKind::kAccel, o, &clock);
  IioSensor gyro(kernel, fs, ImuKind::kGyro, o, &clock);
  std::string error;
  REQUIRE(accel.open("/sys/bus/iio/devices/iio:device0", "/dev/iio:device0", &error) == Status::kOk);
  REQUIRE(gyro.open("/sys/bus/iio/devices/iio:device1", "/dev/iio:device1", &error) == Status::kOk);
  CHECK(attr(fs, "/sys/bus/iio/devices/iio:device0/in_accel_sampling_frequency") == "3");  // 250 Hz
  // Seed the clock map as a running session would have it: device 2 s was seen on the host 10 ms
  // ago (so host = device + offset, offset = host0 - 10 ms - 2 s). Both reads below then arrive
  // later than their device stamps and leave the envelope alone.
  const std::int64_t host0 = monotonic_now_ns();
  const std::int64_t dev_ns = 2'000'000'000LL;
  clock.observe(dev_ns, host0 - 10'000'000LL);

  // Camera upright and still: raw accel y = -1000 mg (LRS: aligned Y ~ -9.8). Device time
  // 2,000,000 µs -> IIO value in ns = µs x 1000.
  std::vector<std::uint8_t> bytes;
  append(&bytes, test::iio_record(100, -1000, 50, dev_ns));
  kernel.push_iio(root + "/dev/iio:device0", bytes);
  ImuAxisSample out[64];
  std::size_t n = 0;
  REQUIRE(accel.read_available(out, 64, &n) == Status::kOk);
  REQUIRE(n == 1);
  CHECK(out[0].v.x() == Approx(-0.1 * 9.80665));
  CHECK(out[0].v.y() == Approx(-9.80665));
  CHECK(out[0].v.z() == Approx(-0.05 * 9.80665));
  const std::int64_t t_acc = out[0].t_ns;

  // 90 deg/s about raw z = 900000 LSB -> body z = -pi/2 rad/s.
  kernel.push_iio(root + "/dev/iio:device1", test::iio_record(0, 0, 900000, dev_ns + 1'000'000));
  REQUIRE(gyro.read_available(out, 64, &n) == Status::kOk);
  REQUIRE(n == 1);
  CHECK(out[0].v.z() == Approx(-kPi / 2));
  // Both streams on one mapped device clock: 1 ms apart (to the drift leak, 100 ppm of the test's run time).
  CHECK(out[0].t_ns - t_acc == Approx(1'000'000).margin(1'000));
  CHECK(t_acc - (host0 - 10'000'000LL) == Approx(0).margin(5'000));
}

TEST_CASE("Malformed, reordered and duplicate IIO records are counted and dropped, allocation-free", "[d455][iio]") {
  const std::string root = ums::test::make_temp_dir("d455_iio_malformed");
  test::FakeKernel kernel;
  test::build_d455_tree(root, &kernel, 16);
  SysFs fs(root);
  DeviceClockMap clock;
  ImuOptions o;
  o.clock = ImuClock::kHostMonotonic;  // stamps pass through unchanged
  IioSensor accel(kernel, fs, ImuKind::kAccel, o, &clock);
  std::string error;
  REQUIRE(accel.open("/sys/bus/iio/devices/iio:device0", "/dev/iio:device0", &error) == Status::kOk);
  CHECK(attr(fs, "/sys/bus/iio/devices/iio:device0/current_timestamp_clock") == "monotonic");
  std::vector<std::uint8_t> bytes;
  append(&bytes, test::iio_record(0, -1000, 0, 1000));      // ok
  append(&bytes, test::iio_record(0, -1000, 0, 0));         // zero timestamp: malformed
  append(&bytes, test::iio_record(0, -1000, 0, 2000));      // ok
  append(&bytes, test::iio_record(0, -1000, 0, 2000));      // duplicate
  append(&bytes, test::iio_record(0, -1000, 0, 1500));      // back in time
  // 16-bit data with garbage in the upper half of the container is still valid (sign-extended).
  append(&bytes, test::iio_record(static_cast<std::int32_t>(0x7FFF0000 | 0xFC18), -1000, 0, 3000));  // x = -1000 mg
  append(&bytes, test::iio_record(0, -1000, 0, 4000));
  bytes.resize(bytes.size() - 10);                          // truncated last record: malformed
  kernel.push_iio(root + "/dev/iio:device0", bytes);
  ImuAxisSample out[64];
  std::size_t n = 0;
  ums::AllocScope scope;
  REQUIRE(accel.read_available(out, 64, &n) == Status::kOk);
  CHECK(scope.allocations() == 0);
  REQUIRE(n == 3);
  CHECK(out[0].t_ns == 1000);
  CHECK(out[1].t_ns == 2000);
  CHECK(out[2].t_ns == 3000);
  CHECK(out[2].v.x() == Approx(9.80665));  // raw x = -1000 mg -> body x = +9.8
  CHECK(accel.stats().malformed == 2);
  CHECK(accel.stats().duplicates == 1);
  CHECK(accel.stats().out_of_order == 1);
  CHECK(accel.stats().records == 3);
  // An impossible magnitude (|a| > 20 g) with 32-bit data is malformed too.
  const std::int64_t host = 5000;
  IioSensor accel32(kernel, fs, ImuKind::kAccel, o, &clock);
  REQUIRE(accel32.open("/sys/bus/iio/devices/iio:device0", "/dev/iio:device0", &error) == Status::kOk);
  std::vector<std::uint8_t> big = test::iio_record(30000, 0, 0, 6000);  // 30 g in 16-bit LSB (1 mg)
  CHECK(accel32.decode(big.data(), big.size(), host, out, 64) == 0);
  CHECK(accel32.stats().malformed == 1);
}

TEST_CASE("IIO set-up refuses a device without the timestamp channel (old kernels)", "[d455][iio]") {
  const std::string root = ums::test::make_temp_dir("d455_iio_nots");
  test::FakeKernel kernel;
  test::build_d455_tree(root, &kernel);
  std::filesystem::remove(root + "/sys/bus/iio/devices/iio:device1/scan_elements/in_timestamp_en");
  SysFs fs(root);
  DeviceClockMap clock;
  IioSensor gyro(kernel, fs, ImuKind::kGyro, ImuOptions{}, &clock);
  std::string error;
  CHECK(gyro.open("/sys/bus/iio/devices/iio:device1", "/dev/iio:device1", &error) == Status::kUnsupported);
  CHECK(error.find("in_timestamp") != std::string::npos);
}
