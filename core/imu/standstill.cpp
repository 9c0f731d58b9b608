#include "core/imu/standstill.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/math/quaternion.hpp"

namespace ums {

void StandstillOptions::validate() const {
  const struct {
    const char* name;
    double value;
  } fields[] = {{"block_s", block_s},
                {"gyro_multiplier", gyro_multiplier},
                {"accel_multiplier", accel_multiplier},
                {"max_gravity_error_m_s2", max_gravity_error_m_s2},
                {"gravity_m_s2", gravity_m_s2},
                {"min_window_s", min_window_s}};
  for (const auto& f : fields) {
    if (!(std::isfinite(f.value) && f.value > 0.0)) {
      throw std::invalid_argument(std::string("StandstillOptions.") + f.name +
                                  " must be finite and > 0, got " + std::to_string(f.value));
    }
  }
  if (min_blocks < 2) {
    throw std::invalid_argument("StandstillOptions.min_blocks must be >= 2, got " +
                                std::to_string(min_blocks));
  }
  if (min_window_s < block_s * min_blocks) {
    throw std::invalid_argument(
        "StandstillOptions.min_window_s must be >= block_s * min_blocks, got " +
        std::to_string(min_window_s));
  }
}

Eigen::Quaterniond attitude_from_gravity(const Eigen::Vector3d& f_b) {
  const Eigen::Matrix3d R =
      Eigen::Quaterniond::FromTwoVectors(f_b.normalized(), Eigen::Vector3d::UnitZ())
          .toRotationMatrix();
  return Eigen::Quaterniond(quat::remove_yaw(R)).normalized();
}

Status detect_standstill(const ImuSample* samples, std::size_t n, const ImuNoise& noise,
                         const StandstillOptions& options, StandstillResult* result) {
  *result = StandstillResult();
  if (n < 2) return Status::kNotEnoughData;
  for (std::size_t k = 0; k < n; ++k) {
    if (!samples[k].gyro_rad_s.allFinite() || !samples[k].accel_m_s2.allFinite()) {
      return Status::kInvalidInput;
    }
    if (k > 0 && samples[k].t_ns <= samples[k - 1].t_ns) return Status::kInvalidInput;
  }
  const double window_s = 1e-9 * static_cast<double>(samples[n - 1].t_ns - samples[0].t_ns);
  if (window_s < options.min_window_s) return Status::kNotEnoughData;
  const double dt = window_s / static_cast<double>(n - 1);
  const std::size_t per_block =
      std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(options.block_s / dt)));
  const std::size_t blocks = n / per_block;
  if (blocks < static_cast<std::size_t>(options.min_blocks)) return Status::kNotEnoughData;

  // Welford over block means: one pass, no storage.
  Eigen::Vector3d g_mean = Eigen::Vector3d::Zero(), g_m2 = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_mean = Eigen::Vector3d::Zero(), a_m2 = Eigen::Vector3d::Zero();
  for (std::size_t b = 0; b < blocks; ++b) {
    Eigen::Vector3d g = Eigen::Vector3d::Zero(), a = Eigen::Vector3d::Zero();
    for (std::size_t k = b * per_block; k < (b + 1) * per_block; ++k) {
      g += samples[k].gyro_rad_s;
      a += samples[k].accel_m_s2;
    }
    g /= static_cast<double>(per_block);
    a /= static_cast<double>(per_block);
    const double count = static_cast<double>(b + 1);
    const Eigen::Vector3d dg = g - g_mean, da = a - a_mean;
    g_mean += dg / count;
    a_mean += da / count;
    g_m2 += dg.cwiseProduct(g - g_mean);
    a_m2 += da.cwiseProduct(a - a_mean);
  }
  const double denom = static_cast<double>(blocks - 1);
  const double block_len_s = dt * static_cast<double>(per_block);
  result->blocks = static_cast<int>(blocks);
  result->gyro_spread_rad_s = std::sqrt(g_m2.maxCoeff() / denom);
  result->accel_spread_m_s2 = std::sqrt(a_m2.maxCoeff() / denom);
  result->gyro_threshold_rad_s =
      options.gyro_multiplier * noise.gyro_noise_density / std::sqrt(block_len_s);
  result->accel_threshold_m_s2 =
      options.accel_multiplier * noise.accel_noise_density / std::sqrt(block_len_s);
  result->mean_gyro_rad_s = g_mean;
  result->mean_accel_m_s2 = a_mean;
  result->gravity_error_m_s2 = a_mean.norm() - options.gravity_m_s2;
  result->q_w_b = attitude_from_gravity(a_mean);
  result->at_rest = result->gyro_spread_rad_s < result->gyro_threshold_rad_s &&
                    result->accel_spread_m_s2 < result->accel_threshold_m_s2 &&
                    std::abs(result->gravity_error_m_s2) < options.max_gravity_error_m_s2;
  return Status::kOk;
}

}  // namespace ums
