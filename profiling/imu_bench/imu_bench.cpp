// umsvins_bench_imu: cost of the IMU hot path.
//   ns per preintegrated sample (midpoint step + covariance + bias Jacobian),
//   ns per residual evaluation with all four Jacobian blocks, ns per repropagated interval,
//   heap allocations of one full preintegrate + evaluate cycle (must be 0).
// Usage: umsvins_bench_imu [intervals] (default 2000 intervals of 100 samples = 0.5 s at 200 Hz).
// Times are thread CPU time. The last line printed is JSON.

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>

#include "core/common/imu_sample.hpp"
#include "core/imu/imu_residual.hpp"
#include "core/imu/preintegration.hpp"
#include "core/math/so3.hpp"
#include "profiling/alloc_counter.hpp"

namespace {

constexpr int kSamplesPerInterval = 100;
constexpr std::int64_t kPeriodNs = 5'000'000;

// A wobbling body: rates ~1 rad/s, specific force ~g plus ~1 m/s^2.
ums::ImuSample sample_at(std::int64_t t_ns) {
  const double t = 1e-9 * static_cast<double>(t_ns);
  ums::ImuSample s;
  s.t_ns = t_ns;
  s.gyro_rad_s = Eigen::Vector3d(0.8 * std::sin(1.3 * t), 0.5 * std::cos(0.7 * t), 0.3);
  s.accel_m_s2 = Eigen::Vector3d(std::sin(0.9 * t), 0.5 * std::cos(1.1 * t), 9.81);
  return s;
}

// Thread CPU time: the build machines are shared, and wall time would mostly measure the
// other processes.
double cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

}  // namespace

int main(int argc, char** argv) {
  const int intervals = argc > 1 ? std::max(1, std::atoi(argv[1])) : 2000;
  static ums::ImuSample samples[kSamplesPerInterval + 1];
  for (int k = 0; k <= kSamplesPerInterval; ++k) samples[k] = sample_at(k * kPeriodNs);
  static ums::Preintegration pre;
  const Eigen::Vector3d g_w(0.0, 0.0, -9.81);
  const Eigen::Vector3d ba(0.02, -0.01, 0.03), bg(0.001, 0.002, -0.001);

  // Preintegration.
  double checksum = 0.0;
  double t0 = cpu_seconds();
  for (int i = 0; i < intervals; ++i) {
    pre.reset(samples[0], ba, bg);
    for (int k = 1; k <= kSamplesPerInterval; ++k) pre.add(samples[k]);
    checksum += pre.alpha().x();
  }
  const double ns_per_sample =
      1e9 * (cpu_seconds() - t0) / (static_cast<double>(intervals) * kSamplesPerInterval);

  // Repropagation of a whole interval.
  t0 = cpu_seconds();
  const int repro = std::max(1, intervals / 10);
  for (int i = 0; i < repro; ++i) {
    pre.repropagate(ba + Eigen::Vector3d::Constant(1e-3 * (i % 7)), bg);
    checksum += pre.beta().y();
  }
  const double us_per_repropagation = 1e6 * (cpu_seconds() - t0) / repro;

  // Residual evaluation with all Jacobians.
  ums::ImuResidual res;
  if (res.init(&pre, g_w) != ums::Status::kOk) {
    std::fprintf(stderr, "umsvins_bench_imu: singular preintegration covariance\n");
    return 1;
  }
  double pose_i[7] = {0, 0, 0, 0, 0, 0, 1}, pose_j[7] = {0.1, 0.2, -0.05, 0.01, 0.02, 0.0, 1.0};
  double sb_i[9] = {0.5, 0.1, 0, 0.02, -0.01, 0.03, 0.001, 0.002, -0.001};
  double sb_j[9] = {0.6, 0.1, 0, 0.02, -0.01, 0.03, 0.001, 0.002, -0.001};
  ums::ImuResidual::Vector15 r;
  ums::ImuResidual::JacobianPose J_pi, J_pj;
  ums::ImuResidual::JacobianSpeedBias J_si, J_sj;
  const int evals = intervals * 20;
  t0 = cpu_seconds();
  for (int i = 0; i < evals; ++i) {
    pose_j[0] = 0.1 + 1e-9 * i;
    res.evaluate(pose_i, sb_i, pose_j, sb_j, r.data(), J_pi.data(), J_si.data(), J_pj.data(),
                 J_sj.data());
    checksum += r(0) + J_pi(0, 0);
  }
  const double ns_per_evaluate = 1e9 * (cpu_seconds() - t0) / evals;

  // Allocations of one full cycle.
  std::uint64_t allocs = 0;
  {
    ums::AllocScope scope;
    pre.reset(samples[0], ba, bg);
    for (int k = 1; k <= kSamplesPerInterval; ++k) pre.add(samples[k]);
    pre.repropagate_if_needed(ba + Eigen::Vector3d::Constant(0.2), bg);
    res.init(&pre, g_w);
    res.evaluate(pose_i, sb_i, pose_j, sb_j, r.data(), J_pi.data(), J_si.data(), J_pj.data(),
                 J_sj.data());
    allocs = scope.allocations();
  }
  const bool counted = ums::alloc_counter_available();

  std::printf("preintegration: %.1f ns per sample (%d intervals x %d samples)\n", ns_per_sample,
              intervals, kSamplesPerInterval);
  std::printf("repropagation:  %.2f us per %d-sample interval\n", us_per_repropagation,
              kSamplesPerInterval);
  std::printf("residual eq.1:  %.1f ns per evaluation with 4 Jacobian blocks\n", ns_per_evaluate);
  std::printf("allocations per preintegrate+evaluate cycle: %llu%s\n",
              static_cast<unsigned long long>(allocs), counted ? "" : " (hooks unavailable)");
  std::printf("(checksum %.6g)\n", checksum);
  std::printf(
      "{\"bench\":\"imu\",\"ns_per_sample\":%.1f,\"us_per_repropagation\":%.2f,"
      "\"ns_per_evaluate\":%.1f,\"allocs_per_cycle\":%llu,\"alloc_hooks\":%s}\n",
      ns_per_sample, us_per_repropagation, ns_per_evaluate, static_cast<unsigned long long>(allocs),
      counted ? "true" : "false");
  return allocs == 0 || !counted ? 0 : 1;
}
