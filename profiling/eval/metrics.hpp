#pragma once
// Absolute trajectory error (ATE) and relative pose error (RPE) of an estimate against ground
// truth, after timestamp association and alignment (alignment.hpp). Both trajectories must place
// the same frame (body or cam0) in the world; see change_frame() in trajectory.hpp.

#include <cstdint>
#include <vector>

#include "profiling/eval/alignment.hpp"
#include "profiling/eval/trajectory.hpp"

namespace ums::eval {

// Pairs (estimate index, ground-truth index) whose stamps differ by at most max_dt_ns, each
// estimate pose matched to the nearest ground-truth stamp (ground-truth poses used once).
struct Association {
  std::vector<std::size_t> est_index;
  std::vector<std::size_t> gt_index;
};
Association associate(const Trajectory& est, const Trajectory& gt, std::int64_t max_dt_ns);

struct ErrorStats {
  std::size_t count = 0;
  double rmse = 0.0, mean = 0.0, median = 0.0, max = 0.0;  // unit of the quantity (m or deg)
};
ErrorStats error_stats(std::vector<double> values);

struct AteResult {
  Alignment alignment;
  ErrorStats translation_m;      // |p_gt - align(p_est)|
  ErrorStats rotation_deg;       // angle of R_gt^T R_align R_est
  std::vector<double> t_s;       // per matched pose: time since the first ground-truth pose, s
  std::vector<double> error_m;   // per matched pose: translation error, m
};

enum class RpeUnit : std::uint8_t { kMetres, kSeconds };

struct RpeResult {
  double delta = 0.0;            // segment length in `unit`
  RpeUnit unit = RpeUnit::kMetres;
  ErrorStats translation_m;      // |trans(E)|, E = (T_gt_i^-1 T_gt_j)^-1 (T_est_i^-1 T_est_j)
  ErrorStats rotation_deg;       // angle(E)
};

struct EvalResult {
  std::size_t estimate_poses = 0, groundtruth_poses = 0, matched = 0;
  AteResult ate;
  std::vector<RpeResult> rpe;
};

struct MetricsOptions {
  AlignMode align = AlignMode::kSe3;
  std::int64_t max_dt_ns = 10'000'000;             // association tolerance, ns
  std::vector<double> rpe_distances_m{1.0, 5.0, 10.0};  // m of ground-truth path length
  std::vector<double> rpe_times_s{1.0, 5.0, 10.0};      // s
};

// Throws std::runtime_error when fewer than 2 poses match or the frames differ.
EvalResult evaluate(const Trajectory& est, const Trajectory& gt, const MetricsOptions& options);

}  // namespace ums::eval
