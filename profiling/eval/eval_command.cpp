#include "profiling/eval/eval_command.hpp"

#include <cmath>
#include <cstdio>
#include <ostream>
#include <stdexcept>

namespace ums::eval {

bool EvalOptions::validate(std::string* error) const {
  auto bad = [&](const std::string& m) {
    if (error != nullptr) *error = m;
    return false;
  };
  if (estimate_path.empty()) return bad("eval: --estimate is required");
  if (groundtruth_path.empty()) return bad("eval: --groundtruth is required");
  if (!(max_dt_s > 0.0)) return bad("eval: max_dt_s must be > 0, got " + std::to_string(max_dt_s));
  return true;
}

EvalResult evaluate_frames(const Trajectory& estimate, const Trajectory& groundtruth,
                           const Eigen::Isometry3d& T_b_c0, const MetricsOptions& options) {
  return evaluate(to_frame(estimate, groundtruth.frame, T_b_c0), groundtruth, options);
}

void print_eval(const EvalResult& r, AlignMode align, std::ostream& out) {
  char line[256];
  std::snprintf(line, sizeof line, "poses: estimate %zu, ground truth %zu, matched %zu; align %s",
                r.estimate_poses, r.groundtruth_poses, r.matched, align_mode_name(align));
  out << line << '\n';
  if (align == AlignMode::kSim3) {
    std::snprintf(line, sizeof line, "sim3 scale: %.6f", r.ate.alignment.scale);
    out << line << '\n';
  }
  const auto& a = r.ate.translation_m;
  std::snprintf(line, sizeof line, "ATE trans [m]: rmse %.4f  mean %.4f  median %.4f  max %.4f", a.rmse,
                a.mean, a.median, a.max);
  out << line << '\n';
  const auto& ar = r.ate.rotation_deg;
  std::snprintf(line, sizeof line, "ATE rot [deg]: rmse %.3f  mean %.3f  median %.3f  max %.3f", ar.rmse,
                ar.mean, ar.median, ar.max);
  out << line << '\n';
  for (const auto& p : r.rpe) {
    if (p.translation_m.count == 0) {
      std::snprintf(line, sizeof line, "RPE %5.1f %s: no segment that long", p.delta,
                    p.unit == RpeUnit::kMetres ? "m" : "s");
    } else {
      std::snprintf(line, sizeof line,
                    "RPE %5.1f %s: trans rmse %.4f m mean %.4f m (%.2f %%), rot rmse %.3f deg mean %.3f deg, n %zu",
                    p.delta, p.unit == RpeUnit::kMetres ? "m" : "s", p.translation_m.rmse, p.translation_m.mean,
                    p.unit == RpeUnit::kMetres ? 100.0 * p.translation_m.mean / p.delta : std::nan(""),
                    p.rotation_deg.rmse, p.rotation_deg.mean, p.translation_m.count);
    }
    out << line << '\n';
  }
}

int run_eval(const EvalOptions& options, std::ostream& out, std::string* error, EvalResult* result) {
  if (!options.validate(error)) return 1;
  try {
    const Trajectory est = read_trajectory(options.estimate_path, options.estimate_format);
    const Trajectory gt = read_trajectory(options.groundtruth_path, options.groundtruth_format);
    const Eigen::Isometry3d T_b_c0 =
        options.cam0_sensor_yaml.empty() ? euroc_T_b_c0() : read_T_BS(options.cam0_sensor_yaml);
    MetricsOptions m;
    m.align = options.align;
    m.max_dt_ns = static_cast<std::int64_t>(std::llround(options.max_dt_s * 1e9));
    m.rpe_distances_m.assign(std::begin(options.rpe_distances_m), std::end(options.rpe_distances_m));
    m.rpe_times_s.assign(std::begin(options.rpe_times_s), std::end(options.rpe_times_s));
    const EvalResult r = evaluate_frames(est, gt, T_b_c0, m);
    out << "frames: estimate " << (est.frame == PoseFrame::kBody ? "body" : "cam0") << ", ground truth "
        << (gt.frame == PoseFrame::kBody ? "body" : "cam0") << " (compared in the ground truth's frame)\n";
    print_eval(r, options.align, out);
    if (result != nullptr) *result = r;
  } catch (const std::exception& e) {
    if (error != nullptr) *error = e.what();
    return 1;
  }
  return 0;
}

}  // namespace ums::eval
