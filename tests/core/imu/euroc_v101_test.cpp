// Real-data acceptance tests on the whole EuRoC V1_01 IMU file (29,120 samples at 200 Hz) and its
// ground truth (../shared/data/README.md): bias and attitude at rest, 0.5 s preintegrated
// rotations against the ground truth, standstill decisions, saturation defaults.

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "core/imu/preintegration.hpp"
#include "core/imu/saturation.hpp"
#include "core/imu/standstill.hpp"
#include "core/math/so3.hpp"
#include "tests/common/test_paths.hpp"

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using ums::ImuSample;
using ums::Status;

constexpr double kRadToDeg = 57.29577951308232;

// A small CSV reader for this test only (the product reader lives in hal/replay).
// IMU rows: t[ns], w_x, w_y, w_z [rad/s], a_x, a_y, a_z [m/s^2].
std::vector<ImuSample> read_imu_csv(const std::string& path) {
  std::ifstream in(path);
  REQUIRE(in.good());
  std::vector<ImuSample> out;
  out.reserve(30000);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    const char* p = line.c_str();
    char* end = nullptr;
    ImuSample s;
    s.t_ns = std::strtoll(p, &end, 10);
    double v[6];
    for (double& x : v) {
      p = end + 1;  // skip the comma
      x = std::strtod(p, &end);
    }
    s.gyro_rad_s = Vector3d(v[0], v[1], v[2]);
    s.accel_m_s2 = Vector3d(v[3], v[4], v[5]);
    out.push_back(s);
  }
  return out;
}

struct GtPose {
  std::int64_t t_ns;
  Vector3d p_w_c;
  Eigen::Quaterniond q_c_w;  // the file's quaternion: world -> camera (R_CW)
};

// Ground-truth rows: t[ns] (printed with a fraction), x, y, z [m], qw, qx, qy, qz.
std::vector<GtPose> read_gt(const std::string& path) {
  std::ifstream in(path);
  REQUIRE(in.good());
  std::vector<GtPose> out;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    const char* p = line.c_str();
    char* end = nullptr;
    GtPose g;
    g.t_ns = std::strtoll(p, &end, 10);  // stops at the '.' of "....143104.0000000000"
    while (*end != ',') ++end;
    double v[7];
    for (double& x : v) {
      p = end + 1;
      x = std::strtod(p, &end);
    }
    g.p_w_c = Vector3d(v[0], v[1], v[2]);
    g.q_c_w = Eigen::Quaterniond(v[3], v[4], v[5], v[6]).normalized();
    out.push_back(g);
  }
  return out;
}

// R_b_c of cam0: the rotation part of T_BS in mav0/cam0/sensor.yaml of V1_01_easy (camera ->
// body = IMU). T_BS (row-major 4x4) is
//   [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,
//    0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,
//   -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,
//    0.0, 0.0, 0.0, 1.0]
Matrix3d R_b_c0() {
  Matrix3d R;
  R << 0.0148655429818, -0.999880929698, 0.00414029679422,  //
      0.999557249008, 0.0149672133247, 0.025715529948,      //
      -0.0257744366974, 0.00375618835797, 0.999660727178;
  // Re-orthonormalise the printed digits.
  return Eigen::Quaterniond(R).normalized().toRotationMatrix();
}

const std::vector<ImuSample>& imu() {
  static const std::vector<ImuSample> data =
      read_imu_csv(ums::test::euroc_micro_dir() + "/mav0/imu0/data.csv");
  return data;
}

// Samples with t in [t0_ns, t1_ns).
std::pair<std::size_t, std::size_t> range(const std::vector<ImuSample>& s, std::int64_t t0_ns,
                                          std::int64_t t1_ns) {
  auto lo = std::lower_bound(s.begin(), s.end(), t0_ns,
                             [](const ImuSample& a, std::int64_t t) { return a.t_ns < t; });
  auto hi = std::lower_bound(s.begin(), s.end(), t1_ns,
                             [](const ImuSample& a, std::int64_t t) { return a.t_ns < t; });
  return {static_cast<std::size_t>(lo - s.begin()), static_cast<std::size_t>(hi - s.begin())};
}

// Preintegrates [ta, tb] with end samples interpolated at ta and tb. Returns gamma = R_bi_bj.
bool preintegrate_window(const std::vector<ImuSample>& s, std::int64_t ta, std::int64_t tb,
                         const Vector3d& bg, ums::Preintegration* pre) {
  const auto [i0, i1] = range(s, ta, tb);  // s[i0] >= ta, s[i1] >= tb
  if (i0 == 0 || i1 >= s.size()) return false;
  const ImuSample first = s[i0].t_ns == ta ? s[i0] : ums::interpolate_imu(s[i0 - 1], s[i0], ta);
  if (pre->reset(first, Vector3d::Zero(), bg) != Status::kOk) return false;
  for (std::size_t k = (s[i0].t_ns == ta ? i0 + 1 : i0); k < i1; ++k) {
    if (pre->add(s[k]) != Status::kOk) return false;
  }
  const ImuSample last = s[i1].t_ns == tb ? s[i1] : ums::interpolate_imu(s[i1 - 1], s[i1], tb);
  return pre->add(last) == Status::kOk;
}

double median(std::vector<double> v) {
  REQUIRE(!v.empty());
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

TEST_CASE("V1_01 real IMU: bias at rest, then 0.5 s preintegrated rotations match ground truth",
          "[imu][euroc][real]") {
  const auto& s = imu();
  REQUIRE(s.size() == 29120);
  const auto gt = read_gt(ums::test::groundtruth_dir() + "/V101_GT.txt");
  REQUIRE(gt.size() > 2000);

  // Gyro bias from the first 4 s (the vehicle stands on the floor).
  const ums::ImuNoise noise;
  const auto [r0, r1] = range(s, s.front().t_ns, s.front().t_ns + 4'000'000'000LL);
  ums::StandstillResult rest;
  REQUIRE(ums::detect_standstill(&s[r0], r1 - r0, noise, ums::StandstillOptions(), &rest) ==
          Status::kOk);
  REQUIRE(rest.at_rest);
  const Vector3d bg = rest.mean_gyro_rad_s;

  // Ground-truth body attitude: R_w_b = R_w_c0 * R_c0_b, with R_w_c0 = R(q)^T (q is R_CW).
  const Matrix3d R_c_b = R_b_c0().transpose();
  auto R_w_b = [&](const GtPose& g) {
    return Matrix3d(g.q_c_w.toRotationMatrix().transpose() * R_c_b);
  };

  // Attitude from rest against the ground truth at its first row (still at rest): tilt only.
  const Matrix3d R_gt0 = R_w_b(gt.front());
  const double tilt_deg =
      std::acos(std::min(1.0, (rest.q_w_b.toRotationMatrix().transpose() * Vector3d::UnitZ())
                                  .dot(R_gt0.transpose() * Vector3d::UnitZ()))) *
      kRadToDeg;

  // Non-overlapping 0.5 s windows (10 ground-truth rows at 20 Hz) during the flight, from 6 s
  // after the first IMU sample (take-off is at ~5 s) to the end. The ground-truth stamps are the
  // cam0 stamps, within 128 ns of every 10th IMU stamp; the window ends are interpolated anyway.
  auto median_error_deg = [&](std::int64_t offset_ns, double* median_rotation_deg, int* windows) {
    ums::Preintegration pre;
    std::vector<double> err, rot;
    for (std::size_t k = 0; k + 10 < gt.size(); k += 10) {
      if (gt[k].t_ns < s.front().t_ns + 6'000'000'000LL) continue;
      if (!preintegrate_window(s, gt[k].t_ns + offset_ns, gt[k + 10].t_ns + offset_ns, bg, &pre)) {
        continue;
      }
      const Matrix3d rel_gt = R_w_b(gt[k]).transpose() * R_w_b(gt[k + 10]);
      err.push_back(ums::so3::angle(Matrix3d(pre.gamma().toRotationMatrix().transpose() * rel_gt)) *
                    kRadToDeg);
      rot.push_back(ums::so3::angle(rel_gt) * kRadToDeg);
    }
    if (median_rotation_deg) *median_rotation_deg = median(rot);
    if (windows) *windows = static_cast<int>(err.size());
    return median(err);
  };

  double median_rot_deg = 0.0;
  int windows = 0;
  const double med = median_error_deg(0, &median_rot_deg, &windows);
  std::printf(
      "V1_01 IMU vs GT: gyro bias at rest [%.5f %.5f %.5f] rad/s, tilt from rest vs GT %.2f deg; "
      "%d windows of 0.5 s, median GT rotation %.2f deg, median preintegration error %.3f deg\n",
      bg.x(), bg.y(), bg.z(), tilt_deg, windows, median_rot_deg, med);
  CHECK(windows > 250);
  CHECK(med < 0.3);  // degrees; well under the 0.5 deg of the acceptance
  // The README quotes ~3 deg between the resting accelerometer and the ground-truth gravity.
  CHECK(tilt_deg < 4.0);

  // Time alignment: shifting the IMU by one sample (5 ms) either way must only make it worse
  // (docs/math-imu.md also lists +-10 ms; left out here to keep the qemu run short).
  for (const std::int64_t off : {-5'000'000LL, 5'000'000LL}) {
    const double m = median_error_deg(off, nullptr, nullptr);
    std::printf("  offset %+.0f ms: median error %.3f deg\n", 1e-6 * static_cast<double>(off), m);
    CHECK(m > med);
  }
}

TEST_CASE("V1_01 real IMU: at rest for the first 4 s, moving during the flight",
          "[imu][euroc][real][standstill]") {
  const auto& s = imu();
  const ums::ImuNoise noise;
  const ums::StandstillOptions opt;
  const std::int64_t t0 = s.front().t_ns;
  ums::StandstillResult r;

  const auto [a0, a1] = range(s, t0, t0 + 4'000'000'000LL);
  REQUIRE(ums::detect_standstill(&s[a0], a1 - a0, noise, opt, &r) == Status::kOk);
  CHECK(r.at_rest);
  std::printf(
      "V1_01 standstill 0-4 s: gyro spread %.4f (threshold %.4f) rad/s, accel spread %.3f "
      "(threshold %.3f) m/s^2, |g| error %.3f m/s^2\n",
      r.gyro_spread_rad_s, r.gyro_threshold_rad_s, r.accel_spread_m_s2, r.accel_threshold_m_s2,
      r.gravity_error_m_s2);
  // Every 1 s window of the rest period is at rest as well.
  for (std::int64_t t = t0; t + 1'000'000'000LL <= t0 + 4'000'000'000LL; t += 500'000'000LL) {
    const auto [b0, b1] = range(s, t, t + 1'000'000'000LL);
    REQUIRE(ums::detect_standstill(&s[b0], b1 - b0, noise, opt, &r) == Status::kOk);
    CHECK(r.at_rest);
  }
  // 1 s windows, half-overlapping, from 10 s to 140 s.
  int moving = 0, total = 0;
  double min_spread = 1e9;
  for (std::int64_t t = t0 + 10'000'000'000LL; t + 1'000'000'000LL <= t0 + 140'000'000'000LL;
       t += 500'000'000LL) {
    const auto [b0, b1] = range(s, t, t + 1'000'000'000LL);
    REQUIRE(ums::detect_standstill(&s[b0], b1 - b0, noise, opt, &r) == Status::kOk);
    ++total;
    moving += r.at_rest ? 0 : 1;
    min_spread = std::min(min_spread, r.gyro_spread_rad_s);
  }
  const double fraction = static_cast<double>(moving) / total;
  std::printf(
      "V1_01 standstill 10-140 s: %d of %d one-second windows moving (%.1f %%), smallest "
      "gyro spread %.4f rad/s\n",
      moving, total, 100.0 * fraction, min_spread);
  CHECK(fraction >= 0.98);
}

TEST_CASE("V1_01 real IMU: the default saturation bounds clip nothing",
          "[imu][euroc][real][saturation]") {
  const auto& s = imu();
  const ums::SaturationOptions opt;
  ums::SaturationElement sat(opt);
  Vector3d max_dg = Vector3d::Zero(), max_da = Vector3d::Zero();
  for (std::size_t k = 0; k < s.size(); ++k) {
    if (k > 0) {
      max_dg = max_dg.cwiseMax((s[k].gyro_rad_s - s[k - 1].gyro_rad_s).cwiseAbs());
      max_da = max_da.cwiseMax((s[k].accel_m_s2 - s[k - 1].accel_m_s2).cwiseAbs());
    }
    ImuSample out;
    sat.apply(s[k], &out);
  }
  std::printf(
      "V1_01 largest per-sample change: gyro [%.3f %.3f %.3f] rad/s (bound %.2f), accel "
      "[%.2f %.2f %.2f] m/s^2 (bound %.1f); saturated samples %llu\n",
      max_dg.x(), max_dg.y(), max_dg.z(), opt.max_gyro_step_rad_s, max_da.x(), max_da.y(),
      max_da.z(), opt.max_accel_step_m_s2,
      static_cast<unsigned long long>(sat.saturated_samples()));
  CHECK(sat.saturated_samples() == 0);
  CHECK(sat.processed_samples() == s.size());
  // The margin: the bounds are at least twice the largest change of the whole flight.
  CHECK(max_dg.maxCoeff() * 2.0 < opt.max_gyro_step_rad_s);
  CHECK(max_da.maxCoeff() * 2.0 < opt.max_accel_step_m_s2);
}
