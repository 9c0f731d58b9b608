#pragma once
// Absolute trajectory error (ATE) and relative pose error (RPE) of an estimate against ground
// truth, after timestamp association and alignment (alignment.hpp). Both trajectories must place
// the same frame (body or cam0) in the world; see change_frame() in trajectory.hpp.

#include <cstdint>
#include <vector>

#include "profiling/eval/alignment.hpp"
#include "profiling/eval/trajectory.hpp"

namespace ums::eval {

// The estimate poses that have a ground truth at their stamp, and that ground truth. Between two
// ground-truth poses each within max_dt_ns of the stamp, it is interpolated there (position
// linearly, attitude by slerp): a 30 fps camera's stamps fall up to 2.5 ms between a 200 Hz
// ground truth's, and the nearest pose would then differ by the motion of that time, which a
// 10 s RPE multiplies (the attitude error turns the whole segment). Otherwise (the stamp is a
// ground-truth stamp, or a gap in the ground truth) the nearest ground-truth pose within
// max_dt_ns, each used once. gt_index: the ground-truth pose at or before the stamp
// (interpolated) or the nearest one.
struct Association {
  std::vector<std::size_t> est_index;
  std::vector<std::size_t> gt_index;
  std::vector<StampedPose> gt_pose;  // the ground truth at the estimate's stamp (t_ns: that stamp
                                     // when interpolated, the ground truth's own otherwise)
  std::size_t interpolated = 0;      // pairs whose ground truth is interpolated
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
