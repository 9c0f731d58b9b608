#pragma once
// A simulated IMU stream (measured samples and the ground truth at the same stamps) and the
// `impulses` scenario's spikes, shared by both IMU generators (simulate.cpp's analytic one for
// the procedural style, decimated_imu.hpp's for the photo style).

#include <cstddef>
#include <random>
#include <vector>

#include "core/common/imu_sample.hpp"
#include "hal/replay/euroc_groundtruth.hpp"

namespace ums::sim {

struct ImuTrack {
  std::vector<ImuSample> samples;                 // measured (noise, bias, impulses)
  std::vector<hal::GroundTruthState> truth;       // at the same stamps, with the true biases
  std::vector<std::size_t> impulse_index;         // samples carrying an impulse
};

// One impulse per 10 s of `span_s` (at least 3) on single samples, at the highest yaw rates
// (|world z of the body rate|, one value per sample), >= 1 s apart: 30-80 m/s^2 on the
// accelerometer and 5-10 rad/s on the gyro in random directions. Draws from rng and n01 (the
// caller's noise streams, so a seed gives one dataset). Sorts track->impulse_index.
void add_impulses(const std::vector<double>& yaw_rate_rad_s, double imu_rate_hz, double span_s,
                  std::mt19937_64& rng, std::normal_distribution<double>& n01, ImuTrack* track);

// The accelerometer kept on every `every`-th sample only and linearly interpolated onto the
// samples between (a slower accelerometer fused onto the gyro's stamps); the samples after the
// last kept one hold it. every <= 1: unchanged.
void interpolate_accel(int every, ImuTrack* track);

}  // namespace ums::sim
