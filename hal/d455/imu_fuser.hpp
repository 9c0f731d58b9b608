#pragma once
// Accel and gyro arrive as two streams at different rates (e.g. gyro 400 Hz, accel 250 Hz): this
// produces one ImuSample per gyro sample with the accel linearly interpolated at the gyro stamp
// (rs4se "lerp", realsense-ros unite_imu_method linear_interpolation; notes §6.5). Gyro samples
// wait (bounded) until an accel sample at or after their stamp exists. Fixed memory, no allocation.

#include <cstdint>

#include "core/common/capacity.hpp"
#include "core/common/imu_sample.hpp"
#include "core/common/ring_buffer.hpp"
#include "core/common/status.hpp"
#include "hal/d455/iio_imu.hpp"

namespace ums::d455 {

struct FuserStats {
  std::uint64_t emitted = 0;
  std::uint64_t gyro_unbracketed = 0;  // gyro older than every accel kept: dropped
  std::uint64_t gyro_overflow = 0;     // waited too long for accel (pending ring full): dropped
  std::uint64_t accel_out_of_order = 0;
  std::uint64_t gyro_out_of_order = 0;
  std::uint64_t output_overflow = 0;   // consumer too slow: newest fused sample dropped
};

class ImuFuser {
 public:
  void push_accel(const ImuAxisSample& a);
  void push_gyro(const ImuAxisSample& g);
  // Oldest fused sample first; kEmpty when none.
  Status pop(ImuSample* out) { return out_.pop(out); }
  std::size_t available() const { return out_.size(); }
  // Stamp of the newest fused sample, or INT64_MIN before the first.
  std::int64_t last_emitted_ns() const { return last_emitted_ns_; }
  const FuserStats& stats() const { return stats_; }

 private:
  void drain();
  RingBuffer<ImuAxisSample, capacity::kD455AccelHistory> accel_;
  RingBuffer<ImuAxisSample, capacity::kD455GyroPending> gyro_;
  RingBuffer<ImuSample, capacity::kD455ImuOutRing> out_;
  std::int64_t last_emitted_ns_ = INT64_MIN;
  FuserStats stats_;
};

}  // namespace ums::d455
