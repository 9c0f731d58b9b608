#include "profiling/stage_timer.hpp"

#include <algorithm>
#include <vector>

namespace ums {

const char* stage_name(Stage stage) {
  switch (stage) {
    case Stage::kPyramid: return "pyramid";
    case Stage::kDetect: return "detect";
    case Stage::kTrack: return "track";
    case Stage::kStereo: return "stereo";
    case Stage::kRansac: return "ransac";
    case Stage::kFrontend: return "frontend";
    case Stage::kPreintegrate: return "preintegrate";
    case Stage::kSolveRound1: return "solve_round1";
    case Stage::kSolveRound2: return "solve_round2";
    case Stage::kMarginalize: return "marginalize";
    case Stage::kBackend: return "backend";
    case Stage::kTotal: return "total";
    case Stage::kCount: break;
  }
  return "unknown";
}

void StageTimes::record(Stage stage, double ms) {
  PerStage& s = stats_[index(stage)];
  s.ring[s.count % kWindow] = static_cast<float>(ms);
  ++s.count;
  s.sum_ms += ms;
  if (ms > s.max_ms) s.max_ms = ms;
}

std::size_t StageTimes::samples(Stage stage, double* out, std::size_t capacity) const {
  const PerStage& s = stats_[index(stage)];
  const std::size_t kept = static_cast<std::size_t>(std::min<std::uint64_t>(s.count, kWindow));
  const std::size_t n = std::min(kept, capacity);
  const std::uint64_t first = s.count - kept;
  for (std::size_t i = 0; i < n; ++i) out[i] = static_cast<double>(s.ring[(first + i) % kWindow]);
  return n;
}

StageSummary StageTimes::summary(Stage stage) const {
  const PerStage& s = stats_[index(stage)];
  StageSummary out;
  out.count = s.count;
  if (s.count == 0) return out;
  // Reporting path: a sorted copy of the kept window.
  std::vector<double> v(static_cast<std::size_t>(std::min<std::uint64_t>(s.count, kWindow)));
  samples(stage, v.data(), v.size());
  std::sort(v.begin(), v.end());
  const auto at = [&v](double q) {
    const std::size_t i = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5);
    return v[std::min(i, v.size() - 1)];
  };
  out.median_ms = at(0.5);
  out.p99_ms = at(0.99);
  out.max_ms = s.max_ms;
  out.mean_ms = s.sum_ms / static_cast<double>(s.count);
  return out;
}

}  // namespace ums
