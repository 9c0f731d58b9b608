#include "hal/sim/decimated_imu.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/math/so3.hpp"
#include "hal/sim/simulate.hpp"
#include "tests/common/test_paths.hpp"

using namespace ums::sim;

namespace {

const char* const kTrajectories[] = {"MH01", "MH02", "MH03", "V101", "V102", "V103", "V201"};

SimTrajectory photo_trajectory(const char* name, double start_s, double duration_s) {
  SimOptions o;
  o.style = SimStyle::kPhoto;
  o.texture_dataset = "unused";
  o.trajectory_path = ums::test::groundtruth_dir() + "/" + name + "_GT.txt";
  o.start_s = start_s;
  o.duration_s = duration_s;
  o.out_dir = "unused";
  return make_trajectory(o, rig_preset(CameraPreset::kEuroc));
}

ums::ImuCalibration noise_free() {
  ums::ImuCalibration imu;
  imu.gyro_noise_density = imu.accel_noise_density = 0.0;
  imu.gyro_random_walk = imu.accel_random_walk = 0.0;
  return imu;
}

// True specific force in the body frame from the trajectory itself, by a 5-point second
// difference with a step (0.1 ms) other than the generator's: an independent evaluation.
Eigen::Vector3d specific_force(const Se3Spline& s, std::int64_t t, double g) {
  const std::int64_t h = 100'000;
  const double hs = 1e-4;
  // Returns a value: translation() of the temporary would be a view into a destroyed object.
  auto p = [&](std::int64_t dt) -> Eigen::Vector3d { return s.evaluate(t + dt).translation(); };
  const Eigen::Vector3d a = (-p(-2 * h) + 16.0 * p(-h) - 30.0 * p(0) + 16.0 * p(h) - p(2 * h)) / (12.0 * hs * hs);
  return s.evaluate(t).linear().transpose() * (a + Eigen::Vector3d(0.0, 0.0, g));
}

}  // namespace

// Acceptance: with the noise off, integrating the gyro (minus its constant bias) over 1 s
// reproduces the trajectory's relative rotation within 0.05 deg, on the aggressive middle part
// of every shared trajectory. Midpoint rule on the 200 Hz samples, as an estimator does.
TEST_CASE("decimated IMU: 1 s of gyro reproduces the trajectory's rotation", "[sim][decimated_imu]") {
  for (const char* name : kTrajectories) {
    const SimTrajectory tr = photo_trajectory(name, 30.0, 20.0);
    DecimatedImuOptions o;
    const ImuTrack imu = generate_decimated_imu(tr.se3, tr.t_begin_ns, tr.t_end_ns, noise_free(), o);
    const double dt = 1.0 / o.output_rate_hz;
    double worst_deg = 0.0;
    for (std::size_t w0 = 0; w0 + 200 < imu.samples.size(); w0 += 100) {
      Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
      for (std::size_t k = w0; k < w0 + 200; ++k) {
        const Eigen::Vector3d w = 0.5 * (imu.samples[k].gyro_rad_s + imu.samples[k + 1].gyro_rad_s) - imu.truth[k].gyro_bias_rad_s;
        q = (q * ums::so3::exp_quat(w * dt)).normalized();
      }
      const Eigen::Quaterniond truth = imu.truth[w0].q_w_b.conjugate() * imu.truth[w0 + 200].q_w_b;
      worst_deg = std::max(worst_deg, ums::so3::angle(truth.conjugate() * q) * 180.0 / M_PI);
    }
    WARN(name << ": worst 1 s gyro integration error " << worst_deg << " deg");
    CHECK(worst_deg < 0.05);
  }
}

// The accelerometer is the mean specific force over the sample's window [t - dt/2, t + dt/2].
// For any f, |mean - f(t)| <= (dt/4) w with w = max |f'(s) - f'(t)| over the window (write
// f(s) - f(t) = f'(t)(s - t) + int (f' - f'(t)), the first term averages to zero, the second is
// <= w |s - t|). The trapezoid over the m sub-steps and the second difference add the same kind
// of term on h = dt/m: bound = (dt + 2h)/4 w + 1e-5 m/s^2 (rounding of the differences).
TEST_CASE("decimated IMU: accelerometer within the derived bound of the trajectory's specific force",
          "[sim][decimated_imu]") {
  const SimTrajectory tr = photo_trajectory("V103", 30.0, 10.0);
  DecimatedImuOptions o;
  const ImuTrack imu = generate_decimated_imu(tr.se3, tr.t_begin_ns, tr.t_end_ns, noise_free(), o);
  const double dt = 1.0 / o.output_rate_hz, h = dt / 10.0;
  const std::int64_t step = 250'000;  // 0.25 ms grid for f'
  double worst_ratio = 0.0, worst_err = 0.0;
  for (std::size_t n = 1; n + 1 < imu.samples.size(); n += 3) {
    const std::int64_t t = imu.samples[n].t_ns;
    const Eigen::Vector3d f_t = specific_force(tr.se3, t, o.gravity_m_s2);
    auto fdot = [&](std::int64_t s) {
      return ((specific_force(tr.se3, s + step, o.gravity_m_s2) - specific_force(tr.se3, s - step, o.gravity_m_s2)) / 5e-4).eval();
    };
    const Eigen::Vector3d fdot_t = fdot(t);
    double w = 0.0;
    for (std::int64_t s = t - 2'500'000; s <= t + 2'500'000; s += step) w = std::max(w, (fdot(s) - fdot_t).norm());
    const double bound = (dt + 2.0 * h) / 4.0 * w + 1e-5;
    const double err = (imu.samples[n].accel_m_s2 - imu.truth[n].accel_bias_m_s2 - f_t).norm();
    worst_ratio = std::max(worst_ratio, err / bound);
    worst_err = std::max(worst_err, err);
  }
  WARN("V103: worst |accel - f| " << worst_err << " m/s^2, worst error / bound " << worst_ratio);
  CHECK(worst_ratio <= 1.0);
  CHECK(worst_err < 0.05);  // what the bound amounts to on V103's fastest 10 s
}

// Integrating the accelerometer over 1 s reaches the trajectory's velocity change (noise off):
// the decimation keeps the integral of the specific force, which preintegration relies on.
TEST_CASE("decimated IMU: 1 s of accelerometer reproduces the velocity change", "[sim][decimated_imu]") {
  const SimTrajectory tr = photo_trajectory("MH03", 30.0, 20.0);
  DecimatedImuOptions o;
  const ImuTrack imu = generate_decimated_imu(tr.se3, tr.t_begin_ns, tr.t_end_ns, noise_free(), o);
  const double dt = 1.0 / o.output_rate_hz;
  const Eigen::Vector3d g(0.0, 0.0, -o.gravity_m_s2);
  double worst = 0.0;
  for (std::size_t w0 = 0; w0 + 200 < imu.samples.size(); w0 += 100) {
    Eigen::Vector3d dv = Eigen::Vector3d::Zero();
    for (std::size_t k = w0; k < w0 + 200; ++k) {
      const Eigen::Vector3d a0 = imu.truth[k].q_w_b * (imu.samples[k].accel_m_s2 - imu.truth[k].accel_bias_m_s2) + g;
      const Eigen::Vector3d a1 = imu.truth[k + 1].q_w_b * (imu.samples[k + 1].accel_m_s2 - imu.truth[k + 1].accel_bias_m_s2) + g;
      dv += 0.5 * (a0 + a1) * dt;
    }
    worst = std::max(worst, (dv - (imu.truth[w0 + 200].v_w_b - imu.truth[w0].v_w_b)).norm());
  }
  WARN("MH03: worst 1 s velocity-change error " << worst << " m/s");
  CHECK(worst < 2e-3);
}

TEST_CASE("decimated IMU: initial biases as large as real ones, written to the ground truth", "[sim][decimated_imu]") {
  const SimTrajectory tr = photo_trajectory("V101", 10.0, 1.0);
  DecimatedImuOptions o;
  Eigen::Vector3d max_bg = Eigen::Vector3d::Zero(), max_ba = Eigen::Vector3d::Zero();
  double mean_abs_bg = 0.0;
  const int seeds = 40;
  for (int seed = 1; seed <= seeds; ++seed) {
    o.seed = static_cast<std::uint64_t>(seed);
    const ImuTrack imu = generate_decimated_imu(tr.se3, tr.t_begin_ns, tr.t_end_ns, ums::ImuCalibration{}, o);
    const Eigen::Vector3d bg = imu.truth.front().gyro_bias_rad_s, ba = imu.truth.front().accel_bias_m_s2;
    max_bg = max_bg.cwiseMax(bg.cwiseAbs());
    max_ba = max_ba.cwiseMax(ba.cwiseAbs());
    mean_abs_bg += bg.cwiseAbs().sum() / (3.0 * seeds);
  }
  WARN("40 seeds: max |bg| " << max_bg.transpose() << ", max |ba| " << max_ba.transpose() << ", mean |bg| " << mean_abs_bg);
  CHECK(max_bg.maxCoeff() <= 0.08);
  CHECK(max_ba.maxCoeff() <= 0.1);
  CHECK(max_bg.minCoeff() > 0.06);   // the range is used (40 draws per axis)
  CHECK(max_ba.minCoeff() > 0.075);
  CHECK(mean_abs_bg == Approx(0.04).margin(0.012));  // uniform in +-0.08: mean |b| = 0.04
}

// With the noise on, the scatter of (measured - true) is the configured white noise:
// std = density * sqrt(rate) per axis (ADIS16448: gyro 2.4e-3 rad/s, accel 0.028 m/s^2 at 200 Hz).
TEST_CASE("decimated IMU: white noise at the configured density", "[sim][decimated_imu]") {
  const SimTrajectory tr = photo_trajectory("V101", 10.0, 20.0);
  DecimatedImuOptions o;
  const ums::ImuCalibration cal;
  const ImuTrack noisy = generate_decimated_imu(tr.se3, tr.t_begin_ns, tr.t_end_ns, cal, o);
  const ImuTrack clean = generate_decimated_imu(tr.se3, tr.t_begin_ns, tr.t_end_ns, noise_free(), o);
  REQUIRE(noisy.samples.size() == clean.samples.size());
  double sg = 0.0, sa = 0.0;
  const double n = static_cast<double>(noisy.samples.size());
  for (std::size_t k = 0; k < noisy.samples.size(); ++k) {
    // Bias random walk differs between the two; subtract each run's own truth bias.
    const Eigen::Vector3d eg = (noisy.samples[k].gyro_rad_s - noisy.truth[k].gyro_bias_rad_s) -
                               (clean.samples[k].gyro_rad_s - clean.truth[k].gyro_bias_rad_s);
    const Eigen::Vector3d ea = (noisy.samples[k].accel_m_s2 - noisy.truth[k].accel_bias_m_s2) -
                               (clean.samples[k].accel_m_s2 - clean.truth[k].accel_bias_m_s2);
    sg += eg.squaredNorm() / (3.0 * n);
    sa += ea.squaredNorm() / (3.0 * n);
  }
  CHECK(std::sqrt(sg) == Approx(cal.gyro_noise_density * std::sqrt(200.0)).epsilon(0.05));
  CHECK(std::sqrt(sa) == Approx(cal.accel_noise_density * std::sqrt(200.0)).epsilon(0.05));
}
