#include "hal/sim/decimated_imu.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/math/so3.hpp"
#include "hal/sim/random_vector.hpp"

namespace ums::sim {
namespace {

struct TrueSample {
  Eigen::Vector3d gyro_rad_s;   // mean body rate over the window
  Eigen::Vector3d accel_m_s2;   // mean specific force over the window
};

// The window of one output stamp: m + 3 poses at t_n - dt/2 + j h, j = -1 .. m + 1.
TrueSample integrate_window(const Se3Spline& spline, std::int64_t t_n, std::int64_t window_ns, int m,
                            const Eigen::Vector3d& g_w, std::vector<Eigen::Isometry3d>* poses) {
  const std::int64_t h_ns = window_ns / m;
  const double h = static_cast<double>(h_ns) * 1e-9;
  const std::int64_t t0 = t_n - (static_cast<std::int64_t>(m) * h_ns) / 2;
  poses->resize(static_cast<std::size_t>(m) + 3);
  for (int j = -1; j <= m + 1; ++j) (*poses)[static_cast<std::size_t>(j + 1)] = spline.evaluate(t0 + j * h_ns);
  auto T = [&](int j) -> const Eigen::Isometry3d& { return (*poses)[static_cast<std::size_t>(j + 1)]; };
  TrueSample s{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  for (int j = 0; j < m; ++j) {
    const Eigen::Matrix3d dR = T(j).linear().transpose() * T(j + 1).linear();
    s.gyro_rad_s += so3::log(dR);
  }
  s.gyro_rad_s /= static_cast<double>(m) * h;
  for (int j = 0; j <= m; ++j) {
    const Eigen::Vector3d a_w =
        (T(j + 1).translation() - 2.0 * T(j).translation() + T(j - 1).translation()) / (h * h);
    const double weight = (j == 0 || j == m) ? 0.5 : 1.0;
    s.accel_m_s2 += weight * (T(j).linear().transpose() * (a_w - g_w));
  }
  s.accel_m_s2 /= static_cast<double>(m);
  return s;
}

hal::GroundTruthState truth_at(const Se3Spline& spline, std::int64_t t_ns, std::int64_t h_ns) {
  const Eigen::Isometry3d T = spline.evaluate(t_ns);
  hal::GroundTruthState gt;
  gt.t_ns = t_ns;
  gt.p_w_b = T.translation();
  gt.q_w_b = Eigen::Quaterniond(T.linear()).normalized();
  gt.v_w_b = (spline.evaluate(t_ns + h_ns).translation() - spline.evaluate(t_ns - h_ns).translation()) /
             (2.0 * static_cast<double>(h_ns) * 1e-9);
  return gt;
}

}  // namespace

std::int64_t decimated_imu_margin_ns(double output_rate_hz) {
  // Half a window plus one internal step for the second difference, with room to spare.
  return 2 * static_cast<std::int64_t>(std::llround(1e9 / output_rate_hz));
}

ImuTrack generate_decimated_imu(const Se3Spline& spline, std::int64_t t_begin_ns, std::int64_t t_end_ns,
                                const ImuCalibration& imu, const DecimatedImuOptions& o) {
  ImuTrack track;
  std::mt19937_64 rng(o.seed * 0xD1B54A32D192ED03ULL + 29);
  std::normal_distribution<double> n01(0.0, 1.0);
  auto nvec = [&] { return draw_vector3([&] { return n01(rng); }); };
  std::uniform_real_distribution<double> u11(-1.0, 1.0);
  auto uvec = [&] { return draw_vector3([&] { return u11(rng); }); };
  const std::int64_t dt_ns = static_cast<std::int64_t>(std::llround(1e9 / o.output_rate_hz));
  const double dt = static_cast<double>(dt_ns) * 1e-9;
  const int m = std::max(1, static_cast<int>(std::lround(o.internal_rate_hz / o.output_rate_hz)));
  const double sg = imu.gyro_noise_density / std::sqrt(dt), sa = imu.accel_noise_density / std::sqrt(dt);
  const double rg = imu.gyro_random_walk * std::sqrt(dt), ra = imu.accel_random_walk * std::sqrt(dt);
  Eigen::Vector3d bg = o.gyro_bias_max_rad_s * uvec();
  Eigen::Vector3d ba = o.accel_bias_max_m_s2 * uvec();
  const Eigen::Vector3d g_w(0.0, 0.0, -o.gravity_m_s2);
  std::vector<Eigen::Isometry3d> poses;
  std::vector<double> yaw_rate;
  for (std::int64_t t = t_begin_ns; t <= t_end_ns; t += dt_ns) {
    const TrueSample s = integrate_window(spline, t, dt_ns, m, g_w, &poses);
    hal::GroundTruthState gt = truth_at(spline, t, dt_ns / m);
    gt.gyro_bias_rad_s = bg;
    gt.accel_bias_m_s2 = ba;
    ImuSample meas;
    meas.t_ns = t;
    meas.gyro_rad_s = s.gyro_rad_s + bg + sg * nvec();
    meas.accel_m_s2 = s.accel_m_s2 + ba + sa * nvec();
    yaw_rate.push_back(std::abs((gt.q_w_b * s.gyro_rad_s).z()));
    track.samples.push_back(meas);
    track.truth.push_back(gt);
    bg += rg * nvec();
    ba += ra * nvec();
  }
  if (o.impulses) {
    add_impulses(yaw_rate, o.output_rate_hz, static_cast<double>(t_end_ns - t_begin_ns) * 1e-9, rng, n01, &track);
  }
  return track;
}

}  // namespace ums::sim
