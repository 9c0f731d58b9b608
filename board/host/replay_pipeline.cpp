#include "board/host/replay_pipeline.hpp"

#include <chrono>

#include "profiling/alloc_counter.hpp"

namespace ums::cli {

ReplayPipeline::ReplayPipeline(const AppConfig& config, const ReplayPipelineOptions& options)
    : config_(config), options_(options), times_(new StageTimes()) {}

ReplayPipeline::~ReplayPipeline() { delete times_; }

void ReplayPipeline::note_time(std::int64_t t_ns) {
  if (first_t_ns_ < 0) first_t_ns_ = t_ns;
  if (t_ns > last_t_ns_) last_t_ns_ = t_ns;
}

void ReplayPipeline::on_imu(const ImuSample& sample) {
  const bool steady = summary_.frames >= options_.steady_state_from_frame;
  AllocScope allocs;
  const auto start = std::chrono::steady_clock::now();

  if (sample.t_ns <= last_imu_t_ns_) {
    ++out_of_order_imu_;  // a source bug: count, never pass on
  } else {
    last_imu_t_ns_ = sample.t_ns;
    ++summary_.imu_samples;
  }
  summary_.processing_s +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (steady) summary_.heap_allocs_steady_state += allocs.allocations();
}

void ReplayPipeline::on_stereo(const StereoFrame& frame) {
  const bool steady = summary_.frames >= options_.steady_state_from_frame;
  AllocScope allocs;
  {
    ScopedStageTimer total(times_, Stage::kTotal);
    const auto start = std::chrono::steady_clock::now();
    note_time(frame.t_ns);
    ++summary_.frames;
    summary_.processing_s +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  if (steady) summary_.heap_allocs_steady_state += allocs.allocations();
}

ReplaySummary ReplayPipeline::summary() const {
  ReplaySummary s = summary_;
  s.duration_s = first_t_ns_ < 0 ? 0.0 : static_cast<double>(last_t_ns_ - first_t_ns_) * 1e-9;
  return s;
}

void ReplayPipeline::write_stats(JsonWriter& w) const {
  w.begin_object("memory")
      .value("heap_allocs_steady_state", summary_.heap_allocs_steady_state)
      .value("alloc_counter", alloc_counter_available())
      .end_object();
  w.begin_object("drops").value("imu_out_of_order", out_of_order_imu_).end_object();
}

void ReplayPipeline::print_summary(std::ostream& out) const {
  out << "replay: steady-state heap allocations in the pipeline: "
      << summary_.heap_allocs_steady_state << "\n";
}

}  // namespace ums::cli
