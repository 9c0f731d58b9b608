#pragma once
// The pipeline's input port. Sources (replay, simulator, D455) push measurements in time order;
// the estimator, the front end alone, or a recorder consume them. Push in, one clock.

#include "core/common/imu_sample.hpp"
#include "core/common/stereo_frame.hpp"

namespace ums {

class MeasurementSink {
 public:
  virtual ~MeasurementSink() = default;
  virtual void on_imu(const ImuSample& sample) = 0;
  virtual void on_stereo(const StereoFrame& frame) = 0;
};

}  // namespace ums
