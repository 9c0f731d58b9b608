#include "hal/sim/imu_track.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace ums::sim;

TEST_CASE("impulses: one per 10 s at the highest yaw rates, >= 1 s apart, sized as specified", "[sim][imu_track]") {
  ImuTrack track;
  std::vector<double> yaw;
  for (int k = 0; k < 200 * 45; ++k) {  // 45 s at 200 Hz; yaw rate peaks at 7 s, 7.5 s, 20 s, 33 s, 40 s (higher later)
    ums::ImuSample s;
    s.t_ns = k * 5'000'000LL;
    track.samples.push_back(s);
    const double t = k / 200.0;
    double y = 0.1;
    for (double peak : {7.0, 7.5, 20.0, 33.0, 40.0}) y += std::exp(-(t - peak) * (t - peak) * 50.0) * (1.0 + peak * 0.01);
    yaw.push_back(y);
  }
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n01(0.0, 1.0);
  add_impulses(yaw, 200.0, 45.0, rng, n01, &track);
  REQUIRE(track.impulse_index.size() == 4u);  // floor(45 / 10)
  // The 7 s peak (lower) loses to the 7.5 s one, 0.5 s away; the others win in yaw-rate order.
  const double expect_s[4] = {7.5, 20.0, 33.0, 40.0};
  for (std::size_t i = 0; i < 4; ++i) {
    const std::size_t idx = track.impulse_index[i];
    CHECK(idx / 200.0 == Approx(expect_s[i]).margin(0.01));
    CHECK(track.samples[idx].accel_m_s2.norm() >= 30.0);
    CHECK(track.samples[idx].accel_m_s2.norm() <= 80.0);
    CHECK(track.samples[idx].gyro_rad_s.norm() >= 5.0);
    CHECK(track.samples[idx].gyro_rad_s.norm() <= 10.0);
  }
}
