// umsvins_bench_sim: stereo pairs per second the simulator renders at 752x480 (EuRoC preset),
// rendering only (no PNG encoding), both cameras. Reports wall-clock and CPU-time rates: on a
// shared machine the CPU-time rate over 2 cores is what the cores deliver when they are ours.
// Usage: umsvins_bench_sim [pairs]   (default 40). Last line JSON.

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <vector>

#include "hal/sim/renderer.hpp"
#include "hal/sim/simulate.hpp"

int main(int argc, char** argv) {
  using namespace ums::sim;
  const int n = argc > 1 ? std::atoi(argv[1]) : 40;
  if (n <= 0) {
    std::fprintf(stderr, "usage: umsvins_bench_sim [pairs > 0]\n");
    return 64;
  }
  SimOptions o;
  o.out_dir = "unused";
  const ums::RigCalibration rig = rig_preset(CameraPreset::kEuroc);
  const SimTrajectory tr = make_trajectory(o, rig);
  std::vector<Eigen::Vector3d> path;
  for (std::int64_t t = tr.t_begin_ns; t <= tr.t_end_ns; t += 100'000'000LL) path.push_back(tr.spline.evaluate(t).p_w_b);
  const World world = make_world(path, WorldOptions{});
  const StereoRenderer renderer(world, rig);
  std::vector<std::uint8_t> left(752 * 480), right(752 * 480);

  const auto t0 = std::chrono::steady_clock::now();
  const std::clock_t c0 = std::clock();
  for (int k = 0; k < n; ++k) {
    const SplineState s = tr.spline.evaluate(tr.t_begin_ns + k * 50'000'000LL);
    Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
    T_w_b.linear() = s.q_w_b.toRotationMatrix();
    T_w_b.translation() = s.p_w_b;
    renderer.render_stereo(T_w_b, RenderOptions{}, static_cast<std::uint64_t>(k), left.data(), right.data());
  }
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu_s = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  const double wall_rate = n / wall_s;
  const double cpu_rate_2cores = n / (cpu_s / 2.0);
  std::printf("rendered %d stereo pairs at 752x480: %.1f pairs/s wall, %.1f pairs/s on 2 cores (CPU time)\n", n,
              wall_rate, cpu_rate_2cores);
  std::printf("{\"pairs\": %d, \"pairs_per_s_wall\": %.2f, \"pairs_per_s_2cores_cpu\": %.2f}\n", n, wall_rate,
              cpu_rate_2cores);
  return 0;
}
