#pragma once
// The estimator's IMU input: time order, the saturation hold, the ring of recent samples the
// standstill test reads, and the open preintegration interval (from the newest frame to the
// next one, which lives in the next window slot). Fixed memory: a RingBuffer and a scratch copy.

#include <cstddef>
#include <cstdint>
#include <memory>

#include <Eigen/Core>

#include "core/common/capacity.hpp"
#include "core/common/imu_sample.hpp"
#include "core/common/ring_buffer.hpp"
#include "core/imu/preintegration.hpp"

namespace ums {

class ImuBuffer {
 public:
  static constexpr std::size_t kRecent = capacity::kStandstillImuSamples;
  static_assert(kRecent >= capacity::kMaxImuSamplesBetweenFrames,
                "the scratch also holds one interval's samples when two are merged");

  struct Added {
    bool accepted = false;      // false: not after the previous sample, dropped
    bool first = false;         // the first sample of the run
    bool held = false;          // saturated: the previous sample was held in its place
    bool interval_full = false; // the open interval had no room
    bool after_gap = false;     // more than max_gap after the previous sample (samples were lost)
  };

  // max_gap_ns: a longer time between samples is a hole (lost samples), not a slow sensor.
  explicit ImuBuffer(std::int64_t max_gap_ns = INT64_MAX);
  // One sample (after the saturation element; saturated: clipped, hold the previous one).
  Added add(const ImuSample& in, bool saturated);
  bool has_samples() const { return have_; }
  const ImuSample& last() const { return last_; }

  // The open interval: started at a frame with linearization biases, fed by add().
  void open_interval(Preintegration* pre, std::int64_t t_ns, const Eigen::Vector3d& ba, const Eigen::Vector3d& bg);
  bool interval_open() const { return open_; }
  // The open interval spans a hole (between its samples, or from its last one to the stamp that
  // closes it): holding a sample across it would integrate motion the IMU never measured.
  bool interval_has_gap() const { return gap_; }
  // lost_ns of time passed after the last sample that the stamps do not show (the clock stepped
  // back): a hole of that length, between the last sample and the next.
  void note_lost_time(std::int64_t lost_ns);
  // How much of the open interval lies in holes (s), and how long the hole had lasted at the end
  // of that part (s): a sample held across a hole drifts from the motion the longer it is held.
  double interval_hole_s() const { return 1e-9 * static_cast<double>(hole_ns_); }
  double hole_age_s() const { return 1e-9 * static_cast<double>(hole_end_ns_ - hole_start_ns_); }
  // How fast the measured motion changed in the second before the latest hole: the mean of
  // (sample step)^2 / dt per axis, gyro (rad^2/s^3) and accel (m^2/s^5). A held sample's error
  // after s seconds has about q * s variance (the signal as a random walk). False: no samples.
  bool motion_density_before_hole(double* q_gyro, double* q_accel) const;
  // Ends the open interval at the frame time (the last sample held to the stamp: samples arrive
  // in time order, so all before the frame are in; holding <= 1/rate is well below the noise).
  // Returns false when the boundary did not fit.
  bool close_interval(std::int64_t t_ns);

  // Recent samples with t in [t0_ns, t1_ns], oldest first, into scratch(); returns the count.
  int copy_recent(std::int64_t t0_ns, std::int64_t t1_ns);
  ImuSample* scratch() { return scratch_.get(); }

 private:
  void note_hole(std::int64_t last_sample_ns, std::int64_t end_ns);
  Status add_bridged(const ImuSample& next);

  std::unique_ptr<RingBuffer<ImuSample, kRecent>> recent_;
  std::unique_ptr<ImuSample[]> scratch_;
  ImuSample last_;
  std::int64_t max_gap_ns_;
  bool have_ = false;
  bool gap_ = false;
  std::int64_t interval_t0_ns_ = 0;
  std::int64_t hole_ns_ = 0;        // hole time inside the open interval
  std::int64_t hole_start_ns_ = 0;  // the last sample before the latest hole
  std::int64_t hole_end_ns_ = 0;    // where the latest hole's part in the open interval ends
  Preintegration* interval_ = nullptr;
  bool open_ = false;
};

}  // namespace ums
