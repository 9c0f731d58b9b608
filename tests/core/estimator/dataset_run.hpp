#pragma once
// Test helper: feeds an opened EuRoC-layout dataset through the front end and an estimator built
// from `options` and `rig` (end-to-end estimator tests without the pipeline's time aligner).

#include <memory>

#include "core/estimator/estimator.hpp"
#include "core/frontend/frontend.hpp"
#include "core/imu/saturation.hpp"
#include "hal/replay/euroc_reader.hpp"

namespace ums::test {

// on_frame(t_ns, output) after every frame the estimator took; *last: the last output.
template <typename OnFrame>
std::unique_ptr<Estimator> run_dataset(hal::EurocReader& reader, const RigCalibration& rig,
                                       const EstimatorOptions& options, EstimatorOutput* last, OnFrame&& on_frame) {
  Frontend frontend(FrontendOptions(), rig);
  auto est = std::make_unique<Estimator>(options, rig);
  auto ff = std::make_unique<FrameFeatures>();
  SaturationElement saturation;
  ImuSample imu;
  StereoFrame frame;
  for (;;) {
    const auto ev = reader.next(&imu, &frame);
    if (ev == hal::EurocReader::Event::kEnd) break;
    if (ev == hal::EurocReader::Event::kImu) {
      ImuSample clipped;
      est->add_imu(clipped, saturation.apply(imu, &clipped));
    } else if (frontend.process(frame, nullptr, ff.get()) == Status::kOk) {
      est->add_frame(*ff, last, nullptr);
      on_frame(frame.t_ns, *last);
    }
  }
  return est;
}

}  // namespace ums::test
