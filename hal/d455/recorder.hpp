#pragma once
// The recorder loop as a library function: drains a D455Device into a sink (the EuRoC writer of
// hal/replay for `umsvins record`) for a bounded time, surviving short stalls by restarting the
// stream. The board program owns argument parsing, the writer and SIGINT.

#include <atomic>
#include <cstdint>
#include <string>

#include "core/common/measurement_sink.hpp"
#include "core/common/status.hpp"
#include "hal/d455/d455_device.hpp"

namespace ums::d455 {

struct RecordOptions {
  double seconds = 0.0;             // s of recording; 0 = until *stop becomes true
  int poll_timeout_ms = 200;        // ms per wait for data
  int stall_restart_ms = 1000;      // ms without any data before the stream is restarted
  int stall_give_up_ms = 5000;      // ms without any data before recording fails with kTimeout
  void validate() const;            // throws std::runtime_error naming the field and value
};

struct RecordSummary {
  std::uint64_t frames = 0;         // stereo pairs written
  std::uint64_t imu_samples = 0;    // fused IMU samples written
  double duration_s = 0.0;          // host time spent recording
  int restarts = 0;                 // stream restarts after stalls
  D455Stats device;                 // the device's counters at the end
};

// Starts the device (already open), records, stops it. kOk at the end of the requested time or
// on stop; kTimeout when the stream stalled beyond stall_give_up_ms; kIoError when the device
// disappeared (error says which). The summary is filled in every case.
Status record(D455Device& device, MeasurementSink& sink, const RecordOptions& options,
              const std::atomic<bool>* stop, RecordSummary* summary, std::string* error);

}  // namespace ums::d455
