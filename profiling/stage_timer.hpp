#pragma once
// Per-stage wall-clock timing into fixed storage: the last kWindow samples of each stage are kept
// for median/p99, count/sum/max over the whole run. No allocation when recording; the summary
// sorts a copy in a caller-provided scratch (start-up sized), so it is for reports, not per frame.
//
//   StageTimes times;
//   { ScopedStageTimer t(&times, Stage::kFrontend); frontend.process(frame); }

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>

namespace ums {

enum class Stage : std::uint8_t {
  kPyramid,
  kDetect,
  kTrack,
  kStereo,
  kRansac,
  kFrontend,
  kPreintegrate,
  kSolveRound1,
  kSolveRound2,
  kMarginalize,
  kBackend,
  kTotal,
  kCount
};

const char* stage_name(Stage stage);  // "frontend", "solve_round1", ... (stats.json keys)

struct StageSummary {
  std::uint64_t count = 0;
  double median_ms = 0.0;
  double p99_ms = 0.0;
  double max_ms = 0.0;
  double mean_ms = 0.0;
};

class StageTimes {
 public:
  static constexpr std::size_t kWindow = 16384;  // samples kept per stage for percentiles

  void record(Stage stage, double ms);
  StageSummary summary(Stage stage) const;
  std::uint64_t count(Stage stage) const { return stats_[index(stage)].count; }
  // The kept samples of a stage, oldest first, for histograms.
  std::size_t samples(Stage stage, double* out, std::size_t capacity) const;

 private:
  struct PerStage {
    std::array<float, kWindow> ring{};
    std::uint64_t count = 0;
    double sum_ms = 0.0;
    double max_ms = 0.0;
  };
  static std::size_t index(Stage s) { return static_cast<std::size_t>(s); }
  std::array<PerStage, static_cast<std::size_t>(Stage::kCount)> stats_{};
};

class ScopedStageTimer {
 public:
  ScopedStageTimer(StageTimes* times, Stage stage)
      : times_(times), stage_(stage), start_(std::chrono::steady_clock::now()) {}
  ~ScopedStageTimer() {
    if (times_ == nullptr) return;
    const auto end = std::chrono::steady_clock::now();
    times_->record(stage_, std::chrono::duration<double, std::milli>(end - start_).count());
  }
  ScopedStageTimer(const ScopedStageTimer&) = delete;
  ScopedStageTimer& operator=(const ScopedStageTimer&) = delete;

 private:
  StageTimes* times_;
  Stage stage_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace ums
