#include "hal/d455/imu_fuser.hpp"

#include <catch2/catch.hpp>

#include "profiling/alloc_counter.hpp"

using namespace ums::d455;

namespace {
// Accel linear in time so interpolation is exact: a(t) = (1 + t_s, -9.81, 2 t_s).
Eigen::Vector3d accel_at(std::int64_t t_ns) {
  const double t = static_cast<double>(t_ns) * 1e-9;
  return {1.0 + t, -9.81, 2.0 * t};
}
}  // namespace

TEST_CASE("ImuFuser interpolates 250 Hz accel onto 400 Hz gyro stamps exactly for linear signals", "[d455][fuser]") {
  ImuFuser f;
  const std::int64_t t0 = 1'000'000'000;
  std::int64_t ta = t0, tg = t0 + 1'000'000;  // first gyro 1 ms after the first accel
  int emitted = 0;
  double max_err = 0.0;
  ums::AllocScope scope;
  for (int step = 0; step < 400; ++step) {
    // Feed in arrival order: whichever stream has the earlier next stamp, like two fds.
    if (ta <= tg) {
      f.push_accel({ta, accel_at(ta)});
      ta += 4'000'000;
    } else {
      f.push_gyro({tg, Eigen::Vector3d(0.1, 0.2, 0.3)});
      tg += 2'500'000;
    }
    ums::ImuSample s;
    while (f.pop(&s) == ums::Status::kOk) {
      max_err = std::max(max_err, (s.accel_m_s2 - accel_at(s.t_ns)).norm());
      CHECK(s.gyro_rad_s.x() == 0.1);
      ++emitted;
    }
  }
  CHECK(scope.allocations() == 0);
  CHECK(max_err < 1e-12);
  CHECK(emitted >= 240);  // 400 pushes at 250+400 Hz: ~246 gyro, all but the last waiting one
  CHECK(f.stats().gyro_unbracketed == 0);
}

TEST_CASE("ImuFuser waits for a later accel, drops gyro older than its accel history and out-of-order input", "[d455][fuser]") {
  ImuFuser f;
  f.push_gyro({100, Eigen::Vector3d::Zero()});  // before any accel: waits, then unbracketed
  f.push_accel({200, Eigen::Vector3d(1, 0, 0)});
  CHECK(f.stats().gyro_unbracketed == 1);
  f.push_gyro({250, Eigen::Vector3d::Zero()});
  CHECK(f.available() == 0);  // waits for an accel at or after 250
  f.push_accel({300, Eigen::Vector3d(3, 0, 0)});
  ums::ImuSample s;
  REQUIRE(f.pop(&s) == ums::Status::kOk);
  CHECK(s.t_ns == 250);
  CHECK(s.accel_m_s2.x() == Approx(2.0));
  f.push_gyro({250, Eigen::Vector3d::Zero()});  // duplicate
  f.push_gyro({240, Eigen::Vector3d::Zero()});  // back in time
  f.push_accel({290, Eigen::Vector3d::Zero()});  // back in time
  CHECK(f.stats().gyro_out_of_order == 2);
  CHECK(f.stats().accel_out_of_order == 1);
  f.push_gyro({300, Eigen::Vector3d::Zero()});  // exactly on an accel stamp
  REQUIRE(f.pop(&s) == ums::Status::kOk);
  CHECK(s.accel_m_s2.x() == 3.0);
  CHECK(f.stats().emitted == 2);
}
