#include "hal/sim/imu_track.hpp"
#include "hal/sim/random_vector.hpp"

#include <algorithm>
#include <cmath>

namespace ums::sim {

void add_impulses(const std::vector<double>& yaw_rate, double imu_rate_hz, double span_s, std::mt19937_64& rng,
                  std::normal_distribution<double>& n01, ImuTrack* track) {
  if (track->samples.empty()) return;
  auto nvec = [&] { return draw_vector3([&] { return n01(rng); }); };
  const std::size_t want = static_cast<std::size_t>(std::max(3.0, std::floor(span_s / 10.0)));
  std::vector<std::size_t> order(yaw_rate.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return yaw_rate[a] > yaw_rate[b]; });
  const std::size_t sep = static_cast<std::size_t>(imu_rate_hz);
  std::uniform_real_distribution<double> ua(30.0, 80.0), ug(5.0, 10.0);
  for (std::size_t idx : order) {
    if (track->impulse_index.size() >= want) break;
    bool far = true;
    for (std::size_t j : track->impulse_index) far = far && (idx > j ? idx - j : j - idx) >= sep;
    if (!far) continue;
    track->impulse_index.push_back(idx);
    // Direction, then size: the draws in one statement each (random_vector.hpp says why), in the
    // order of the datasets made so far.
    const Eigen::Vector3d accel_dir = nvec().normalized();
    track->samples[idx].accel_m_s2 += ua(rng) * accel_dir;
    const Eigen::Vector3d gyro_dir = nvec().normalized();
    track->samples[idx].gyro_rad_s += ug(rng) * gyro_dir;
  }
  std::sort(track->impulse_index.begin(), track->impulse_index.end());
}

void interpolate_accel(int every, ImuTrack* track) {
  if (every <= 1) return;
  std::vector<ImuSample>& m = track->samples;
  const std::size_t n = m.size();
  for (std::size_t a = 0; a < n; a += static_cast<std::size_t>(every)) {
    const std::size_t b = a + static_cast<std::size_t>(every);
    for (std::size_t i = a + 1; i < std::min(b, n); ++i) {
      if (b >= n) {
        m[i].accel_m_s2 = m[a].accel_m_s2;
        continue;
      }
      const double f = static_cast<double>(m[i].t_ns - m[a].t_ns) / static_cast<double>(m[b].t_ns - m[a].t_ns);
      m[i].accel_m_s2 = (1.0 - f) * m[a].accel_m_s2 + f * m[b].accel_m_s2;
    }
  }
}

}  // namespace ums::sim
