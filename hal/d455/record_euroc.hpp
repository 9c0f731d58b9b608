#pragma once
// `umsvins record` in one call: a D455 session written as an EuRoC-layout dataset (PNG stereo,
// IMU csv, sensor.yaml from the calibration) through hal/replay's EurocWriter, so a field
// recording replays on the host with `umsvins replay`.

#include <atomic>
#include <string>

#include "core/common/calibration.hpp"
#include "core/common/status.hpp"
#include "hal/d455/recorder.hpp"

namespace ums::d455 {

// device: opened (D455Device::open), not started. out_dir: the dataset folder (mav0/ is created
// inside). Throws std::runtime_error when out_dir cannot be created or a file write failed (the
// writer's message); otherwise returns record()'s status, with *error set when not kOk.
Status record_euroc(D455Device& device, const RigCalibration& calibration, const std::string& out_dir,
                    const RecordOptions& options, const std::atomic<bool>* stop, RecordSummary* summary,
                    std::string* error);

}  // namespace ums::d455
