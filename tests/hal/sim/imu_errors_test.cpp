#include "hal/sim/imu_errors.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "hal/sim/imu_track.hpp"
#include "hal/sim/simulate.hpp"
#include "tests/common/test_paths.hpp"

using namespace ums::sim;

namespace {

// A track at `rate_hz` for `span_s` whose samples are `gyro` / `accel` plus the biases bg / ba
// (also in the truth), no noise: what apply_imu_errors adds is all that differs afterwards.
ImuTrack constant_track(double rate_hz, double span_s, const Eigen::Vector3d& gyro, const Eigen::Vector3d& accel,
                        const Eigen::Vector3d& bg = Eigen::Vector3d::Zero(),
                        const Eigen::Vector3d& ba = Eigen::Vector3d::Zero()) {
  ImuTrack track;
  const auto n = static_cast<std::size_t>(std::lround(rate_hz * span_s));
  for (std::size_t k = 0; k < n; ++k) {
    ums::ImuSample s;
    s.t_ns = 1'000'000'000LL + std::llround(static_cast<double>(k) * 1e9 / rate_hz);
    s.gyro_rad_s = gyro + bg;
    s.accel_m_s2 = accel + ba;
    ums::hal::GroundTruthState gt;
    gt.t_ns = s.t_ns;
    gt.gyro_bias_rad_s = bg;
    gt.accel_bias_m_s2 = ba;
    track.samples.push_back(s);
    track.truth.push_back(gt);
  }
  return track;
}

// Mean of (sample - truth bias) over the track: the sensed quantity after M, vibration averaged out.
Eigen::Vector3d mean_sensed(const ImuTrack& t, bool gyro) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < t.samples.size(); ++i) {
    sum += gyro ? Eigen::Vector3d(t.samples[i].gyro_rad_s - t.truth[i].gyro_bias_rad_s)
                : Eigen::Vector3d(t.samples[i].accel_m_s2 - t.truth[i].accel_bias_m_s2);
  }
  return sum / static_cast<double>(t.samples.size());
}

// One-sided power spectrum of x sampled at rate_hz (plain DFT, bins k = 0..n/2), for band ratios.
std::vector<double> power_spectrum(const std::vector<double>& x) {
  const std::size_t n = x.size();
  std::vector<double> p(n / 2 + 1, 0.0);
  for (std::size_t k = 0; k < p.size(); ++k) {
    // Goertzel recurrence for bin k.
    const double w = 2.0 * M_PI * static_cast<double>(k) / static_cast<double>(n);
    const double c = 2.0 * std::cos(w);
    double s1 = 0.0, s2 = 0.0;
    for (double v : x) {
      const double s0 = v + c * s1 - s2;
      s2 = s1;
      s1 = s0;
    }
    p[k] = s1 * s1 + s2 * s2 - c * s1 * s2;
  }
  return p;
}

// Fraction of the (non-DC) power within [lo_hz, hi_hz].
double band_fraction(const std::vector<double>& x, double rate_hz, double lo_hz, double hi_hz) {
  const std::vector<double> p = power_spectrum(x);
  double in = 0.0, all = 0.0;
  for (std::size_t k = 1; k < p.size(); ++k) {
    const double f_hz = static_cast<double>(k) * rate_hz / static_cast<double>(x.size());
    all += p[k];
    if (f_hz >= lo_hz && f_hz <= hi_hz) in += p[k];
  }
  return in / all;
}

double rms(const std::vector<double>& x) {
  double s = 0.0;
  for (double v : x) s += v * v;
  return std::sqrt(s / static_cast<double>(x.size()));
}

ImuErrorOptions only_vibration() {
  ImuErrorOptions o;
  o.gyro_scale_max = o.accel_scale_max = 0.0;
  o.gyro_misalignment_max_rad = o.accel_misalignment_max_rad = 0.0;
  o.gyro_drift_rad_s = o.accel_drift_m_s2 = 0.0;
  return o;
}

}  // namespace

TEST_CASE("imu errors: scale factor and misalignment measured back from constant rates and gravity at rest",
          "[sim][imu_errors]") {
  ImuErrorOptions o;
  o.gyro_drift_rad_s = o.accel_drift_m_s2 = 0.0;
  const ImuErrorDraw d = draw_imu_errors(o, 7);
  // The planted values are of the configured size (0.5 %, 0.2 deg = 3.5e-3 rad) and not zero.
  for (int i = 0; i < 3; ++i) {
    CHECK(std::abs(d.gyro_scale(i)) <= o.gyro_scale_max);
    CHECK(std::abs(d.accel_scale(i)) <= o.accel_scale_max);
    for (int j = 0; j < 3; ++j) {
      if (i == j) continue;
      CHECK(std::abs(d.M_gyro(i, j) / d.M_gyro(i, i)) <= o.gyro_misalignment_max_rad);
      CHECK(std::abs(d.M_accel(i, j) / d.M_accel(i, i)) <= o.accel_misalignment_max_rad);
    }
  }
  CHECK(d.gyro_scale.cwiseAbs().maxCoeff() > 0.1 * o.gyro_scale_max);
  CHECK((d.M_accel - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 0.1 * o.accel_misalignment_max_rad);
  const Eigen::Vector3d bg(0.003, -0.002, 0.001), ba(0.05, 0.02, -0.04);
  // Without vibration the 10 s means give M to rounding; with it (0.5 m/s^2, 0.02 rad/s at
  // 60-80 Hz) its residual mean leaves ~2e-5, against entries of 1e-3..5e-3.
  for (const double vibration_scale : {0.0, 1.0}) {
    ImuErrorOptions ov = o;
    ov.vibration_accel_rms_m_s2 *= vibration_scale;
    ov.vibration_gyro_rms_rad_s *= vibration_scale;
    const double tol = vibration_scale > 0.0 ? 1e-4 : 1e-12;
    Eigen::Matrix3d M_gyro, M_accel;
    for (int axis = 0; axis < 3; ++axis) {
      // 1 rad/s about one axis; gravity's reaction (9.81 m/s^2) along the same axis at rest.
      ImuTrack t = constant_track(200.0, 10.0, Eigen::Vector3d::Unit(axis), 9.81 * Eigen::Vector3d::Unit(axis), bg, ba);
      apply_imu_errors(ov, d, 7, &t);
      M_gyro.col(axis) = mean_sensed(t, true);
      M_accel.col(axis) = mean_sensed(t, false) / 9.81;
    }
    // The samples carry exactly the planted values, the bias outside M.
    INFO("vibration x" << vibration_scale << "\nM_gyro measured\n" << M_gyro << "\nplanted\n" << d.M_gyro);
    CHECK((M_gyro - d.M_gyro).cwiseAbs().maxCoeff() < tol);
    INFO("M_accel measured\n" << M_accel << "\nplanted\n" << d.M_accel);
    CHECK((M_accel - d.M_accel).cwiseAbs().maxCoeff() < tol);
    for (int i = 0; i < 3; ++i) {
      CHECK(M_gyro(i, i) - 1.0 == Approx(d.gyro_scale(i)).margin(tol));
      CHECK(M_accel(i, i) - 1.0 == Approx(d.accel_scale(i)).margin(tol));
    }
  }
}

TEST_CASE("imu errors: the vibration sits in the aliased rotor band with the configured RMS", "[sim][imu_errors][slow]") {
  const ImuErrorOptions o = only_vibration();  // 130 +- 10 Hz, 0.5 m/s^2, 0.02 rad/s
  const ImuErrorDraw d = draw_imu_errors(o, 3);
  struct Case {
    double rate_hz, lo_hz, hi_hz;  // the band as the samples see it
  };
  // 200 Hz folds 120..140 Hz to 60..80 Hz; 1000 Hz sees it where it is.
  for (const Case c : {Case{200.0, 60.0, 80.0}, Case{1000.0, 120.0, 140.0}}) {
    ImuTrack t = constant_track(c.rate_hz, 20.0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
    apply_imu_errors(o, d, 3, &t);
    for (int axis = 0; axis < 3; ++axis) {
      std::vector<double> a, g;
      for (const auto& s : t.samples) {
        a.push_back(s.accel_m_s2(axis));
        g.push_back(s.gyro_rad_s(axis));
      }
      INFO("rate " << c.rate_hz << " Hz, axis " << axis);
      CHECK(rms(a) == Approx(o.vibration_accel_rms_m_s2).epsilon(0.1));
      CHECK(rms(g) == Approx(o.vibration_gyro_rms_rad_s).epsilon(0.1));
      if (axis == 0) {  // the DFT is O(n^2): one axis per sensor
        CHECK(band_fraction(a, c.rate_hz, c.lo_hz, c.hi_hz) > 0.97);
        CHECK(band_fraction(g, c.rate_hz, c.lo_hz, c.hi_hz) > 0.97);
        CHECK(band_fraction(a, c.rate_hz, 0.0, 0.5 * c.lo_hz) < 0.01);  // nothing slow: it averages out
      }
    }
  }
}

TEST_CASE("imu errors: the warm-up drift reaches 63 % of its drawn end after one time constant", "[sim][imu_errors]") {
  ImuErrorOptions o;
  o.gyro_scale_max = o.accel_scale_max = 0.0;
  o.gyro_misalignment_max_rad = o.accel_misalignment_max_rad = 0.0;  // vibration on: averaged over 1 s
  const ImuErrorDraw d = draw_imu_errors(o, 11);
  for (int i = 0; i < 3; ++i) {
    CHECK(std::abs(d.gyro_drift_end_rad_s(i)) >= 0.5 * o.gyro_drift_rad_s);
    CHECK(std::abs(d.gyro_drift_end_rad_s(i)) <= o.gyro_drift_rad_s);
    CHECK(std::abs(d.accel_drift_end_m_s2(i)) >= 0.5 * o.accel_drift_m_s2);
    CHECK(std::abs(d.accel_drift_end_m_s2(i)) <= o.accel_drift_m_s2);
  }
  ImuTrack t = constant_track(200.0, 301.0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  apply_imu_errors(o, d, 11, &t);
  // Mean over the 1 s window starting at t_s (200 samples).
  auto window = [&](double t_s, bool gyro) {
    const auto k0 = static_cast<std::size_t>(t_s * 200.0);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (std::size_t k = k0; k < k0 + 200; ++k) sum += gyro ? t.samples[k].gyro_rad_s : t.samples[k].accel_m_s2;
    return Eigen::Vector3d(sum / 200.0);
  };
  const double tau = o.drift_time_constant_s;
  // The window [0, 1] s: the ramp's mean there is ~ 0.5 / tau of the end.
  CHECK((window(0.0, true) - d.gyro_drift_end_rad_s * 0.5 / tau).cwiseAbs().maxCoeff() < 2e-4);
  CHECK((window(0.0, false) - d.accel_drift_end_m_s2 * 0.5 / tau).cwiseAbs().maxCoeff() < 3e-3);
  const double at_tau = 1.0 - std::exp(-1.0);  // 0.632
  CHECK((window(tau - 0.5, true) - at_tau * d.gyro_drift_end_rad_s).cwiseAbs().maxCoeff() < 2e-4);
  CHECK((window(tau - 0.5, false) - at_tau * d.accel_drift_end_m_s2).cwiseAbs().maxCoeff() < 3e-3);
  CHECK((window(299.0, true) - d.gyro_drift_end_rad_s).cwiseAbs().maxCoeff() < 2e-4);   // 5 tau: 99.3 %
  CHECK((window(299.0, false) - d.accel_drift_end_m_s2).cwiseAbs().maxCoeff() < 3e-3);
  // The drift is a bias: the truth's biases carry it (at the last sample, exactly).
  const double ramp_end = 1.0 - std::exp(-(static_cast<double>(t.samples.back().t_ns - t.samples.front().t_ns) * 1e-9) / tau);
  CHECK((t.truth.back().gyro_bias_rad_s - ramp_end * d.gyro_drift_end_rad_s).norm() < 1e-12);
  CHECK((t.truth.back().accel_bias_m_s2 - ramp_end * d.accel_drift_end_m_s2).norm() < 1e-12);
}

TEST_CASE("imu errors: deterministic per seed, seeds differ", "[sim][imu_errors]") {
  const ImuErrorOptions o;
  const ImuErrorDraw a = draw_imu_errors(o, 1), b = draw_imu_errors(o, 1), c = draw_imu_errors(o, 2);
  CHECK(a.M_gyro == b.M_gyro);
  CHECK(a.accel_drift_end_m_s2 == b.accel_drift_end_m_s2);
  CHECK(a.M_gyro != c.M_gyro);
  ImuTrack t1 = constant_track(200.0, 1.0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  ImuTrack t2 = t1;
  apply_imu_errors(o, a, 1, &t1);
  apply_imu_errors(o, b, 1, &t2);
  for (std::size_t i = 0; i < t1.samples.size(); ++i) CHECK(t1.samples[i].accel_m_s2 == t2.samples[i].accel_m_s2);
}

TEST_CASE("imu model: realistic = ideal's samples with the errors applied, truth poses unchanged, ideal ignores "
          "the error settings", "[sim][imu_errors]") {
  for (const SimStyle style : {SimStyle::kProcedural, SimStyle::kPhoto}) {
    SimOptions o;
    o.style = style;
    o.texture_dataset = "unused";
    o.trajectory_path = ums::test::groundtruth_dir() + "/V102_GT.txt";
    o.start_s = 20.0;
    o.duration_s = 5.0;
    o.seed = 4;
    o.out_dir = "unused";
    const ums::RigCalibration rig = rig_preset(CameraPreset::kEuroc);
    const SimTrajectory tr = make_trajectory(o, rig);
    const ImuTrack ideal = generate_imu(tr, rig.imu, o);
    SimOptions loud = o;  // settings that would change everything, but the model is ideal
    loud.imu_errors.vibration_accel_rms_m_s2 = 5.0;
    loud.imu_errors.gyro_scale_max = 0.1;
    const ImuTrack ideal_loud = generate_imu(tr, rig.imu, loud);
    SimOptions real = o;
    real.imu_model = ImuModel::kRealistic;
    const ImuTrack realistic = generate_imu(tr, rig.imu, real);
    ImuTrack expect = ideal;
    apply_imu_errors(real.imu_errors, draw_imu_errors(real.imu_errors, o.seed), o.seed, &expect);
    REQUIRE(realistic.samples.size() == ideal.samples.size());
    double max_change = 0.0;
    for (std::size_t i = 0; i < ideal.samples.size(); ++i) {
      CHECK(ideal_loud.samples[i].accel_m_s2 == ideal.samples[i].accel_m_s2);
      CHECK(ideal_loud.samples[i].gyro_rad_s == ideal.samples[i].gyro_rad_s);
      CHECK(realistic.samples[i].accel_m_s2 == expect.samples[i].accel_m_s2);
      CHECK(realistic.samples[i].gyro_rad_s == expect.samples[i].gyro_rad_s);
      CHECK(realistic.truth[i].p_w_b == ideal.truth[i].p_w_b);
      CHECK(realistic.truth[i].q_w_b.coeffs() == ideal.truth[i].q_w_b.coeffs());
      max_change = std::max(max_change, (realistic.samples[i].accel_m_s2 - ideal.samples[i].accel_m_s2).norm());
    }
    CHECK(max_change > 0.5);  // vibration of 0.5 m/s^2 RMS per axis
  }
}

TEST_CASE("imu model: sim_events.csv records the settings and the drawn values, unknown names rejected",
          "[sim][imu_errors]") {
  ImuModel m = ImuModel::kIdeal;
  CHECK(parse_imu_model("realistic", &m));
  CHECK(m == ImuModel::kRealistic);
  CHECK_FALSE(parse_imu_model("real", &m));
  const std::string root = (std::filesystem::temp_directory_path() / "ums_imu_errors_events").string();
  std::filesystem::remove_all(root);
  SimOptions o;
  o.trajectory_path = ums::test::groundtruth_dir() + "/MH01_GT.txt";
  o.start_s = 10.0;
  o.duration_s = 1.0;
  o.max_frames = 0;
  o.seed = 9;
  o.imu_model = ImuModel::kRealistic;
  o.out_dir = root;
  std::string err;
  REQUIRE(simulate(o, &err) == 0);
  std::string events;
  {
    std::FILE* f = std::fopen((root + "/sim_events.csv").c_str(), "rb");
    REQUIRE(f != nullptr);
    char buf[4096];
    std::size_t n = 0;
    while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) events.append(buf, n);
    std::fclose(f);
  }
  const ImuErrorDraw d = draw_imu_errors(o.imu_errors, 9);
  INFO(events);
  CHECK(events.find(imu_errors_header(o.imu_errors, d)) != std::string::npos);
  char scale[64];
  std::snprintf(scale, sizeof scale, "gyro_scale %.6g", d.gyro_scale(0));
  CHECK(events.find(scale) != std::string::npos);
  o.imu_errors.drift_time_constant_s = 0.0;
  CHECK_FALSE(o.validate(&err));
  CHECK(err.find("drift_time_constant_s") != std::string::npos);
  std::filesystem::remove_all(root);
}

TEST_CASE("imu errors: select_imu_errors keeps the named errors and zeroes the others", "[sim][imu_errors]") {
  ImuErrorOptions o;
  REQUIRE(select_imu_errors("scale,drift", &o));
  CHECK(o.vibration_accel_rms_m_s2 == 0.0);
  CHECK(o.vibration_gyro_rms_rad_s == 0.0);
  CHECK(o.gyro_misalignment_max_rad == 0.0);
  CHECK(o.accel_scale_max == ImuErrorOptions().accel_scale_max);
  CHECK(o.gyro_drift_rad_s == ImuErrorOptions().gyro_drift_rad_s);
  const ImuErrorDraw d = draw_imu_errors(o, 2);
  CHECK((d.M_gyro - Eigen::Matrix3d(d.M_gyro.diagonal().asDiagonal())).norm() == 0.0);  // no misalignment
  ImuErrorOptions all;
  REQUIRE(select_imu_errors("all", &all));
  CHECK(all.vibration_accel_rms_m_s2 == ImuErrorOptions().vibration_accel_rms_m_s2);
  CHECK_FALSE(select_imu_errors("scale,wobble", &all));
}
