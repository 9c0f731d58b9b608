#include "profiling/eval/error_budget.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <ostream>
#include <stdexcept>

#include <Eigen/Geometry>

#include "profiling/eval/alignment.hpp"
#include "profiling/eval/metrics.hpp"
#include "profiling/json_writer.hpp"

namespace ums::eval {
namespace {

constexpr double kRadToDeg = 57.29577951308232;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
const char* const kKnownModes[] = {"IMU_ONLY", "VO", "VIO"};

// Estimate/ground-truth pairs after association, in time order.
struct Matched {
  std::vector<std::int64_t> t_ns;  // estimate stamps
  std::vector<Eigen::Vector3d> p_est, p_gt;
  std::vector<Eigen::Quaterniond> q_est, q_gt;
};

Matched match(const Trajectory& est, const Trajectory& gt, std::int64_t max_dt_ns) {
  if (est.frame != gt.frame) {
    throw std::runtime_error("error budget: estimate and ground truth place different frames (body vs cam0)");
  }
  const Association as = associate(est, gt, max_dt_ns);
  if (as.est_index.size() < 3) {
    throw std::runtime_error("error budget: only " + std::to_string(as.est_index.size()) + " poses matched in time");
  }
  Matched m;
  for (std::size_t k = 0; k < as.est_index.size(); ++k) {
    const StampedPose& e = est.poses[as.est_index[k]];
    const StampedPose& g = as.gt_pose[k];
    m.t_ns.push_back(e.t_ns);
    m.p_est.push_back(e.p_w_x);
    m.q_est.push_back(e.q_w_x);
    m.p_gt.push_back(g.p_w_x);
    m.q_gt.push_back(g.q_w_x);
  }
  return m;
}

double rms_of(const std::vector<double>& e, const std::vector<std::size_t>& which) {
  if (which.empty()) return kNaN;
  double sum2 = 0.0;
  for (std::size_t k : which) sum2 += e[k] * e[k];
  return std::sqrt(sum2 / static_cast<double>(which.size()));
}

// Phase order: the three estimator modes always (scripts can rely on them), then any other name
// the timeline uses, in order of appearance.
std::vector<std::string> phase_names(const ModeTimeline& tl) {
  std::vector<std::string> names(std::begin(kKnownModes), std::end(kKnownModes));
  auto add = [&](const std::string& n) {
    if (std::find(names.begin(), names.end(), n) == names.end()) names.push_back(n);
  };
  add(tl.initial_mode);
  for (const ModeEntry& c : tl.changes) add(c.mode);
  return names;
}

// Time in each mode between a and b (ns since the timeline's origin).
std::vector<double> time_in_modes(const ModeTimeline& tl, const std::vector<std::string>& names, std::int64_t a,
                                  std::int64_t b) {
  std::vector<double> seconds(names.size(), 0.0);
  std::int64_t seg_begin = std::numeric_limits<std::int64_t>::min();
  const std::string* mode = &tl.initial_mode;
  for (std::size_t i = 0; i <= tl.changes.size(); ++i) {
    const std::int64_t seg_end = i < tl.changes.size() ? tl.changes[i].since_origin_ns
                                                       : std::numeric_limits<std::int64_t>::max();
    const std::int64_t lo = std::max(seg_begin, a), hi = std::min(seg_end, b);
    const auto at = std::find(names.begin(), names.end(), *mode) - names.begin();
    if (hi > lo) seconds[static_cast<std::size_t>(at)] += static_cast<double>(hi - lo) * 1e-9;
    if (i < tl.changes.size()) {
      seg_begin = seg_end;
      mode = &tl.changes[i].mode;
    }
  }
  return seconds;
}

// Fills b->phases; returns each pose's phase index (into b->phases).
std::vector<std::size_t> split_by_mode(const Matched& m, const ModeTimeline& tl, std::int64_t timeline_origin_ns,
                                       ErrorBudget* b) {
  const std::vector<std::string> names = phase_names(tl);
  std::vector<std::vector<std::size_t>> members(names.size());
  std::vector<std::size_t> phase_of(m.t_ns.size());
  for (std::size_t k = 0; k < m.t_ns.size(); ++k) {
    const std::string& mode = tl.mode_at(m.t_ns[k] - timeline_origin_ns);
    phase_of[k] = static_cast<std::size_t>(std::find(names.begin(), names.end(), mode) - names.begin());
    members[phase_of[k]].push_back(k);
  }
  const std::vector<double> seconds =
      time_in_modes(tl, names, m.t_ns.front() - timeline_origin_ns, m.t_ns.back() - timeline_origin_ns);
  const double total2 = b->ate_rmse_m * b->ate_rmse_m * static_cast<double>(b->poses);
  for (std::size_t i = 0; i < names.size(); ++i) {
    PhaseError p;
    p.mode = names[i];
    p.poses = members[i].size();
    p.duration_s = seconds[i];
    p.ate_rmse_m = rms_of(b->error_m, members[i]);
    p.share_of_ate2 = p.poses == 0 || total2 <= 0.0 ? 0.0 : static_cast<double>(p.poses) * p.ate_rmse_m * p.ate_rmse_m / total2;
    b->phases.push_back(p);
  }
  return phase_of;
}

// Yaw of each estimate attitude against the truth: the ZYX yaw of R_est R_gt^T (the rotation
// about world z taking the true attitude to the estimated one), unwrapped along the flight. ZYX
// yaw is exact under a change of yaw gauge: yaw(Rz(a) M) = a + yaw(M).
std::vector<double> yaw_offsets_deg(const Matched& m) {
  std::vector<double> yaw(m.t_ns.size());
  for (std::size_t k = 0; k < m.t_ns.size(); ++k) {
    const Eigen::Matrix3d d = m.q_est[k].toRotationMatrix() * m.q_gt[k].toRotationMatrix().transpose();
    double y = std::atan2(d(1, 0), d(0, 0)) * kRadToDeg;
    if (k > 0) y += 360.0 * std::round((yaw[k - 1] - y) / 360.0);
    yaw[k] = y;
  }
  return yaw;
}

// Least-squares slope of y over x.
double slope(const std::vector<double>& x, const std::vector<double>& y) {
  double mx = 0.0, my = 0.0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    mx += x[k];
    my += y[k];
  }
  mx /= static_cast<double>(x.size());
  my /= static_cast<double>(x.size());
  double sxy = 0.0, sxx = 0.0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    sxy += (x[k] - mx) * (y[k] - my);
    sxx += (x[k] - mx) * (x[k] - mx);
  }
  return sxx > 0.0 ? sxy / sxx : kNaN;
}

// Anchor on the first anchor_s seconds, in the four directions a VIO cannot observe: yaw = mean
// yaw offset of those poses (from the attitudes, well posed even when the start hardly moves,
// where a fit of positions is not), translation = mean of p_gt - Rz p_est. Tilt is observable
// (gravity), so a tilt error stays in the figures rather than being aligned away.
void drift_figures(const Matched& m, const BudgetOptions& o, ErrorBudget* b) {
  const std::int64_t anchor_ns = static_cast<std::int64_t>(std::llround(o.anchor_s * 1e9));
  const std::vector<double> yaw = yaw_offsets_deg(m);
  std::size_t n = 0;
  double yaw_anchor = 0.0;
  for (; n < m.t_ns.size() && m.t_ns[n] - m.t_ns.front() <= anchor_ns; ++n) yaw_anchor += yaw[n];
  yaw_anchor /= static_cast<double>(n);
  b->anchor_s = static_cast<double>(m.t_ns[n - 1] - m.t_ns.front()) * 1e-9;
  const Eigen::Matrix3d R_a = Eigen::AngleAxisd(-yaw_anchor / kRadToDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Eigen::Vector3d t_a = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < n; ++k) t_a += m.p_gt[k] - R_a * m.p_est[k];
  t_a /= static_cast<double>(n);

  b->yaw_error_end_deg = yaw.back() - yaw_anchor;
  std::vector<double> t_min(b->t_s.size());
  for (std::size_t k = 0; k < t_min.size(); ++k) t_min[k] = b->t_s[k] / 60.0;
  b->yaw_drift_deg_per_min = slope(t_min, yaw);

  b->final_drift_m = (m.p_gt.back() - (R_a * m.p_est.back() + t_a)).norm();
  for (std::size_t k = 1; k < m.p_gt.size(); ++k) b->distance_m += (m.p_gt[k] - m.p_gt[k - 1]).norm();
  b->final_drift_pct = b->distance_m > 1e-6 ? 100.0 * b->final_drift_m / b->distance_m : kNaN;
}

// Windows [t_i, t_i + W) starting at each matched pose and lying inside the flight
// (t_i + W <= t_N); the largest RMSE wins, the earliest on an exact tie. Each window is summed
// afresh rather than by a running sum, whose rounding would drift over a long flight (and could go
// below zero); an hour at 20 Hz with 100 poses per window is 7 M additions.
void find_worst_window(const Matched& m, const BudgetOptions& o, const std::vector<std::size_t>* phase_of,
                       ErrorBudget* b) {
  const std::int64_t w_ns = static_cast<std::int64_t>(std::llround(o.window_s * 1e9));
  WorstWindow& w = b->worst;
  for (std::size_t i = 0; i < m.t_ns.size() && m.t_ns[i] + w_ns <= m.t_ns.back(); ++i) {
    double sum2 = 0.0;
    std::size_t j = i;
    for (; j < m.t_ns.size() && m.t_ns[j] < m.t_ns[i] + w_ns; ++j) sum2 += b->error_m[j] * b->error_m[j];
    const double rmse = std::sqrt(sum2 / static_cast<double>(j - i));
    if (!w.found || rmse > w.rmse_m) {
      w.found = true;
      w.rmse_m = rmse;
      w.poses = j - i;
      w.start_t_ns = m.t_ns[i];
      w.start_s = b->t_s[i];
      w.end_s = w.start_s + o.window_s;
    }
  }
  if (!w.found || phase_of == nullptr) return;
  std::vector<std::size_t> count(b->phases.size(), 0);
  for (std::size_t k = 0; k < m.t_ns.size(); ++k) {
    if (m.t_ns[k] >= w.start_t_ns && m.t_ns[k] < w.start_t_ns + w_ns) ++count[(*phase_of)[k]];
  }
  const std::size_t best = static_cast<std::size_t>(std::max_element(count.begin(), count.end()) - count.begin());
  w.mode = b->phases[best].mode;
  w.mode_share = static_cast<double>(count[best]) / static_cast<double>(w.poses);
}

}  // namespace

ErrorBudget compute_error_budget(const Trajectory& est, const Trajectory& gt, const ModeTimeline* timeline,
                                 const BudgetOptions& options) {
  if (!(options.window_s > 0.0) || !(options.anchor_s >= 0.0)) {
    throw std::runtime_error("error budget: window_s must be > 0 and anchor_s >= 0");
  }
  const Matched m = match(est, gt, options.max_dt_ns);
  ErrorBudget b;
  b.poses = m.t_ns.size();
  b.window_s = options.window_s;
  b.origin_is_first_frame = timeline != nullptr && timeline->origin_known;
  b.origin_t_ns = b.origin_is_first_frame ? timeline->origin_t_ns : m.t_ns.front();
  for (std::int64_t t : m.t_ns) b.t_s.push_back(static_cast<double>(t - b.origin_t_ns) * 1e-9);
  b.duration_s = static_cast<double>(m.t_ns.back() - m.t_ns.front()) * 1e-9;

  const Alignment se3 = align(m.p_est, m.p_gt, AlignMode::kSe3);
  double sum2 = 0.0;
  for (std::size_t k = 0; k < b.poses; ++k) {
    b.error_m.push_back((m.p_gt[k] - se3.apply(m.p_est[k])).norm());
    sum2 += b.error_m.back() * b.error_m.back();
  }
  b.ate_rmse_m = std::sqrt(sum2 / static_cast<double>(b.poses));

  std::vector<std::size_t> phase_of;
  if (timeline != nullptr) {
    b.has_phases = true;
    phase_of = split_by_mode(m, *timeline, b.origin_t_ns, &b);
  }
  b.sim3_scale = align(m.p_est, m.p_gt, AlignMode::kSim3).scale;
  b.scale_error_pct = b.sim3_scale > 0.0 ? 100.0 * (1.0 / b.sim3_scale - 1.0) : kNaN;
  drift_figures(m, options, &b);
  find_worst_window(m, options, timeline != nullptr ? &phase_of : nullptr, &b);
  return b;
}

namespace {

// Fixed decimals, "n/a" for NaN (a figure that has no value on this flight).
std::string fmt(double v, int decimals, bool sign = false) {
  if (!std::isfinite(v)) return "n/a";
  if (std::fabs(v) < 0.5 * std::pow(10.0, -decimals)) v = 0.0;  // no "-0.000"
  char b[64];
  if (sign) std::snprintf(b, sizeof b, "%+.*f", decimals, v);
  else std::snprintf(b, sizeof b, "%.*f", decimals, v);
  return b;
}

}  // namespace

void print_error_budget(const ErrorBudget& b, std::ostream& out) {
  char line[256];
  std::snprintf(line, sizeof line, "error budget (global SE(3) over %zu matched poses, %.2f s; times in s since %s):",
                b.poses, b.duration_s, b.origin_is_first_frame ? "the first frame" : "the first matched pose");
  out << line << '\n';
  out << "  whole flight: ATE rmse " << fmt(b.ate_rmse_m, 4) << " m\n";
  if (!b.has_phases) {
    out << "  per mode: no split (no mode timeline: pass --stats <replay>/stats.json)\n";
  }
  for (const PhaseError& p : b.phases) {
    if (p.poses == 0) {
      std::snprintf(line, sizeof line, "  %-8s: no matched pose, %.2f s", p.mode.c_str(), p.duration_s);
    } else {
      std::snprintf(line, sizeof line, "  %-8s: ATE rmse %.4f m over %zu poses, %.2f s, %.1f %% of ATE^2",
                    p.mode.c_str(), p.ate_rmse_m, p.poses, p.duration_s, 100.0 * p.share_of_ate2);
    }
    out << line << '\n';
  }
  out << "  scale error (sim3): " << fmt(b.scale_error_pct, 3, true) << " % (sim3 scale " << fmt(b.sim3_scale, 6)
      << ")\n";
  out << "  yaw (anchored on the first " << fmt(b.anchor_s, 1) << " s): end error "
      << fmt(b.yaw_error_end_deg, 3, true) << " deg, drift " << fmt(b.yaw_drift_deg_per_min, 3, true) << " deg/min\n";
  out << "  final drift: " << fmt(b.final_drift_m, 4) << " m over " << fmt(b.distance_m, 2)
      << " m travelled = " << fmt(b.final_drift_pct, 3) << " %\n";
  const WorstWindow& w = b.worst;
  if (!w.found) {
    out << "  worst " << fmt(b.window_s, 1) << " s: flight shorter than the window\n";
    return;
  }
  std::snprintf(line, sizeof line, "  worst %.1f s: %.2f-%.2f s, rmse %.4f m over %zu poses", b.window_s, w.start_s,
                w.end_s, w.rmse_m, w.poses);
  out << line;
  if (!w.mode.empty()) out << ", mode " << w.mode << " (" << fmt(100.0 * w.mode_share, 0) << " % of its poses)";
  out << '\n';
}

void write_error_budget_json(const ErrorBudget& b, JsonWriter& w) {
  w.value("alignment", "se3")
      .value("origin_t_ns", b.origin_t_ns)
      .value("origin", b.origin_is_first_frame ? "first_frame" : "first_matched_pose")
      .value("matched_poses", static_cast<std::uint64_t>(b.poses))
      .value("duration_s", b.duration_s, 6)
      .value("ate_rmse_m", b.ate_rmse_m, 6)
      .value("has_phases", b.has_phases);
  w.begin_object("phases");
  for (const PhaseError& p : b.phases) {
    w.begin_object(p.mode.c_str())
        .value("poses", static_cast<std::uint64_t>(p.poses))
        .value("duration_s", p.duration_s, 6)
        .value("ate_rmse_m", p.ate_rmse_m, 6)
        .value("share_of_ate2", p.share_of_ate2, 6)
        .end_object();
  }
  w.end_object();
  w.value("sim3_scale", b.sim3_scale, 8)
      .value("scale_error_pct", b.scale_error_pct, 6)
      .value("anchor_s", b.anchor_s, 6)
      .value("yaw_error_end_deg", b.yaw_error_end_deg, 6)
      .value("yaw_drift_deg_per_min", b.yaw_drift_deg_per_min, 6)
      .value("final_drift_m", b.final_drift_m, 6)
      .value("distance_m", b.distance_m, 6)
      .value("final_drift_pct", b.final_drift_pct, 6);
  w.begin_object("worst_window").value("length_s", b.window_s, 6).value("found", b.worst.found);
  if (b.worst.found) {
    w.value("start_s", b.worst.start_s, 6)
        .value("end_s", b.worst.end_s, 6)
        .value("start_t_ns", b.worst.start_t_ns)
        .value("rmse_m", b.worst.rmse_m, 6)
        .value("poses", static_cast<std::uint64_t>(b.worst.poses))
        .value("mode", b.worst.mode)
        .value("mode_share", b.worst.mode_share, 6);
  }
  w.end_object();
}

}  // namespace ums::eval
