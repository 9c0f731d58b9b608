#include "hal/d455/recorder.hpp"

#include <stdexcept>

#include "hal/d455/time_base.hpp"

namespace ums::d455 {

void RecordOptions::validate() const {
  if (!(seconds >= 0.0)) throw std::runtime_error("record: seconds must be >= 0, got " + std::to_string(seconds));
  if (poll_timeout_ms < 1 || poll_timeout_ms > 10000) {
    throw std::runtime_error("record: poll_timeout_ms must be in [1, 10000], got " + std::to_string(poll_timeout_ms));
  }
  if (stall_restart_ms < poll_timeout_ms || stall_give_up_ms < stall_restart_ms) {
    throw std::runtime_error("record: need poll_timeout_ms <= stall_restart_ms <= stall_give_up_ms");
  }
}

namespace {
// Counts what passes through to the real sink.
class CountingSink final : public MeasurementSink {
 public:
  explicit CountingSink(MeasurementSink& inner) : inner_(inner) {}
  void on_imu(const ImuSample& s) override {
    ++imu;
    inner_.on_imu(s);
  }
  void on_stereo(const StereoFrame& f) override {
    ++frames;
    inner_.on_stereo(f);
  }
  std::uint64_t imu = 0;
  std::uint64_t frames = 0;

 private:
  MeasurementSink& inner_;
};
}  // namespace

Status record(D455Device& device, MeasurementSink& sink, const RecordOptions& options,
              const std::atomic<bool>* stop, RecordSummary* summary, std::string* error) {
  options.validate();
  *summary = RecordSummary{};
  CountingSink counting(sink);
  Status status = device.start(error);
  const std::int64_t start_ns = monotonic_now_ns();
  const auto end_ns = start_ns + static_cast<std::int64_t>(options.seconds * 1e9);
  std::int64_t last_data_ns = start_ns;
  bool restarted_this_stall = false;
  while (status == Status::kOk) {
    const std::int64_t now_ns = monotonic_now_ns();
    if (stop != nullptr && stop->load(std::memory_order_relaxed)) break;
    if (options.seconds > 0.0 && now_ns >= end_ns) break;
    const std::uint64_t before = counting.frames + counting.imu;
    const Status s = device.poll_once(counting, options.poll_timeout_ms);
    if (s == Status::kIoError) {
      *error = "d455: device lost while recording (unplugged?)";
      status = s;
      break;
    }
    const std::int64_t after_ns = monotonic_now_ns();
    if (counting.frames + counting.imu != before) {
      last_data_ns = after_ns;
      restarted_this_stall = false;
      continue;
    }
    const std::int64_t stalled_ms = (after_ns - last_data_ns) / 1000000;
    if (stalled_ms >= options.stall_give_up_ms) {
      *error = "d455: no data for " + std::to_string(stalled_ms) + " ms";
      status = Status::kTimeout;
    } else if (stalled_ms >= options.stall_restart_ms && !restarted_this_stall) {
      restarted_this_stall = true;
      ++summary->restarts;
      std::string restart_error;
      if (device.camera().restart(&restart_error) != Status::kOk) {
        *error = restart_error;
        status = Status::kIoError;
      }
    }
  }
  device.flush(counting);
  device.stop();
  summary->frames = counting.frames;
  summary->imu_samples = counting.imu;
  summary->duration_s = static_cast<double>(monotonic_now_ns() - start_ns) * 1e-9;
  summary->device = device.stats();
  return status;
}

}  // namespace ums::d455
