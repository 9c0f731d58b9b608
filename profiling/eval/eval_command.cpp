#include "profiling/eval/eval_command.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <ostream>
#include <stdexcept>

#include "profiling/json_writer.hpp"

namespace ums::eval {

bool EvalOptions::validate(std::string* error) const {
  auto bad = [&](const std::string& m) {
    if (error != nullptr) *error = m;
    return false;
  };
  if (estimate_path.empty()) return bad("eval: --estimate is required");
  if (groundtruth_path.empty()) return bad("eval: --groundtruth is required");
  if (!(max_dt_s > 0.0)) return bad("eval: max_dt_s must be > 0, got " + std::to_string(max_dt_s));
  if (!(budget.window_s > 0.0)) return bad("eval: budget window must be > 0 s, got " + std::to_string(budget.window_s));
  if (!(budget.anchor_s >= 0.0)) return bad("eval: budget anchor must be >= 0 s, got " + std::to_string(budget.anchor_s));
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

namespace {

// No sample (an RPE segment longer than the flight): null figures, not zeros.
void write_stats_json(const char* key, const ErrorStats& s, const char* unit, JsonWriter& w) {
  const double none = std::nan("");
  w.begin_object(key)
      .value("rmse", s.count > 0 ? s.rmse : none, 6)
      .value("mean", s.count > 0 ? s.mean : none, 6)
      .value("median", s.count > 0 ? s.median : none, 6)
      .value("max", s.count > 0 ? s.max : none, 6)
      .value("count", static_cast<std::uint64_t>(s.count))
      .value("unit", unit)
      .end_object();
}

}  // namespace

void write_eval_json(const std::string& path, const EvalOptions& options, const EvalResult& r,
                     const ErrorBudget* budget) {
  JsonWriter w;
  w.begin_object()
      .value("estimate", options.estimate_path)
      .value("groundtruth", options.groundtruth_path)
      .value("align", align_mode_name(options.align))
      .value("estimate_poses", static_cast<std::uint64_t>(r.estimate_poses))
      .value("groundtruth_poses", static_cast<std::uint64_t>(r.groundtruth_poses))
      .value("matched_poses", static_cast<std::uint64_t>(r.matched));
  w.begin_object("ate").value("scale", r.ate.alignment.scale, 8);
  write_stats_json("trans_m", r.ate.translation_m, "m", w);
  write_stats_json("rot_deg", r.ate.rotation_deg, "deg", w);
  w.end_object();
  w.begin_array("rpe");
  for (const RpeResult& p : r.rpe) {
    w.begin_object().value("delta", p.delta).value("unit", p.unit == RpeUnit::kMetres ? "m" : "s");
    write_stats_json("trans_m", p.translation_m, "m", w);
    write_stats_json("rot_deg", p.rotation_deg, "deg", w);
    w.end_object();
  }
  w.end_array();
  if (budget != nullptr) {
    w.begin_object("budget");
    write_error_budget_json(*budget, w);
    w.end_object();
  } else {
    w.null("budget");
  }
  w.end_object();
  std::ofstream f(path);
  if (!f) throw std::runtime_error(path + ": cannot open for writing");
  f << w.str() << '\n';
  if (!f) throw std::runtime_error(path + ": write failed");
}

int run_eval(const EvalOptions& options, std::ostream& out, std::string* error, EvalResult* result,
             ErrorBudget* budget) {
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
    const Trajectory est_in_gt = to_frame(est, gt.frame, T_b_c0);
    const EvalResult r = evaluate(est_in_gt, gt, m);
    out << "frames: estimate " << (est.frame == PoseFrame::kBody ? "body" : "cam0") << ", ground truth "
        << (gt.frame == PoseFrame::kBody ? "body" : "cam0") << " (compared in the ground truth's frame)\n";
    print_eval(r, options.align, out);
    BudgetOptions bo = options.budget;
    bo.max_dt_ns = m.max_dt_ns;
    std::optional<ErrorBudget> b;
    try {
      b = compute_error_budget(est_in_gt, gt, options.modes ? &*options.modes : nullptr, bo);
      print_error_budget(*b, out);
    } catch (const std::runtime_error& e) {
      // ATE/RPE stand on their own (2 poses suffice there): the budget is extra, not a failure.
      out << "error budget: not computed (" << e.what() << ")\n";
    }
    if (!options.json_path.empty()) write_eval_json(options.json_path, options, r, b ? &*b : nullptr);
    if (result != nullptr) *result = r;
    if (budget != nullptr && b) *budget = *b;
  } catch (const std::exception& e) {
    if (error != nullptr) *error = e.what();
    return 1;
  }
  return 0;
}

}  // namespace ums::eval
