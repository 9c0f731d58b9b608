#include "profiling/eval/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ums::eval {
namespace {

constexpr double kRadToDeg = 57.29577951308232;

double angle_deg(const Eigen::Quaterniond& q) {
  return 2.0 * std::atan2(q.vec().norm(), std::abs(q.w())) * kRadToDeg;
}

}  // namespace

namespace {

// The ground truth at t between a and b (a.t_ns < t < b.t_ns).
StampedPose interpolate(const StampedPose& a, const StampedPose& b, std::int64_t t) {
  const double f = static_cast<double>(t - a.t_ns) / static_cast<double>(b.t_ns - a.t_ns);
  StampedPose g;
  g.t_ns = t;
  g.p_w_x = a.p_w_x + f * (b.p_w_x - a.p_w_x);
  g.q_w_x = a.q_w_x.slerp(f, b.q_w_x).normalized();
  return g;
}

}  // namespace

Association associate(const Trajectory& est, const Trajectory& gt, std::int64_t max_dt_ns) {
  Association a;
  if (gt.poses.empty()) return a;
  std::size_t j = 0;
  std::size_t last_gt = static_cast<std::size_t>(-1);
  for (std::size_t i = 0; i < est.poses.size(); ++i) {
    const std::int64_t t = est.poses[i].t_ns;
    while (j + 1 < gt.poses.size() && gt.poses[j + 1].t_ns <= t) ++j;
    const StampedPose& g0 = gt.poses[j];
    if (g0.t_ns < t && j + 1 < gt.poses.size() && t - g0.t_ns <= max_dt_ns &&
        gt.poses[j + 1].t_ns - t <= max_dt_ns) {
      a.est_index.push_back(i);
      a.gt_index.push_back(j);
      a.gt_pose.push_back(interpolate(g0, gt.poses[j + 1], t));
      ++a.interpolated;
      continue;
    }
    std::size_t best = j;
    if (j + 1 < gt.poses.size() &&
        std::llabs(gt.poses[j + 1].t_ns - t) < std::llabs(gt.poses[j].t_ns - t)) {
      best = j + 1;
    }
    if (std::llabs(gt.poses[best].t_ns - t) > max_dt_ns || best == last_gt) continue;
    a.est_index.push_back(i);
    a.gt_index.push_back(best);
    a.gt_pose.push_back(gt.poses[best]);
    last_gt = best;
  }
  return a;
}

ErrorStats error_stats(std::vector<double> values) {
  ErrorStats s;
  s.count = values.size();
  if (values.empty()) return s;
  double sum = 0.0, sum2 = 0.0;
  for (double v : values) {
    sum += v;
    sum2 += v * v;
    s.max = std::max(s.max, v);
  }
  s.mean = sum / static_cast<double>(values.size());
  s.rmse = std::sqrt(sum2 / static_cast<double>(values.size()));
  const std::size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + static_cast<long>(mid), values.end());
  s.median = values[mid];
  if (values.size() % 2 == 0) {
    s.median = 0.5 * (s.median + *std::max_element(values.begin(), values.begin() + static_cast<long>(mid)));
  }
  return s;
}

EvalResult evaluate(const Trajectory& est, const Trajectory& gt, const MetricsOptions& options) {
  if (est.frame != gt.frame) {
    throw std::runtime_error("evaluate: estimate and ground truth place different frames (body vs cam0)");
  }
  EvalResult r;
  r.estimate_poses = est.poses.size();
  r.groundtruth_poses = gt.poses.size();
  const Association as = associate(est, gt, options.max_dt_ns);
  r.matched = as.est_index.size();
  if (r.matched < 2) {
    throw std::runtime_error("evaluate: only " + std::to_string(r.matched) +
                             " poses matched in time (tolerance " +
                             std::to_string(static_cast<double>(options.max_dt_ns) * 1e-6) + " ms)");
  }
  std::vector<Eigen::Vector3d> pe, pg;
  for (std::size_t k = 0; k < r.matched; ++k) {
    pe.push_back(est.poses[as.est_index[k]].p_w_x);
    pg.push_back(as.gt_pose[k].p_w_x);
  }
  r.ate.alignment = align(pe, pg, options.align);
  const Alignment& al = r.ate.alignment;
  const Eigen::Quaterniond q_align(al.R_gt_est);

  // Aligned estimate poses (scale applies to positions only).
  std::vector<Eigen::Vector3d> pa(r.matched);
  std::vector<Eigen::Quaterniond> qa(r.matched);
  std::vector<double> et, er;
  const std::int64_t t0 = gt.poses.front().t_ns;
  for (std::size_t k = 0; k < r.matched; ++k) {
    pa[k] = al.apply(pe[k]);
    qa[k] = q_align * est.poses[as.est_index[k]].q_w_x;
    const auto& g = as.gt_pose[k];
    et.push_back((pa[k] - g.p_w_x).norm());
    er.push_back(angle_deg(g.q_w_x.conjugate() * qa[k]));
    r.ate.t_s.push_back(static_cast<double>(g.t_ns - t0) * 1e-9);
  }
  r.ate.error_m = et;
  r.ate.translation_m = error_stats(et);
  r.ate.rotation_deg = error_stats(er);

  // Cumulative ground-truth path length at each matched pose, for distance-based RPE.
  std::vector<double> dist(r.matched, 0.0);
  for (std::size_t k = 1; k < r.matched; ++k) dist[k] = dist[k - 1] + (pg[k] - pg[k - 1]).norm();

  auto rpe_for = [&](double delta, RpeUnit unit) {
    RpeResult out;
    out.delta = delta;
    out.unit = unit;
    std::vector<double> ts, rs;
    std::size_t j = 0;
    for (std::size_t i = 0; i < r.matched; ++i) {
      j = std::max(j, i + 1);
      auto reached = [&](std::size_t jj) {
        if (unit == RpeUnit::kMetres) return dist[jj] - dist[i] >= delta - 1e-9;
        return static_cast<double>(as.gt_pose[jj].t_ns - as.gt_pose[i].t_ns) * 1e-9 >=
               delta - 1e-6;
      };
      while (j < r.matched && !reached(j)) ++j;
      if (j >= r.matched) break;
      const auto& gi = as.gt_pose[i];
      const auto& gj = as.gt_pose[j];
      // Relative motions expressed in frame i: d = R_i^T (p_j - p_i), dq = q_i^-1 q_j.
      const Eigen::Vector3d d_gt = gi.q_w_x.conjugate() * (gj.p_w_x - gi.p_w_x);
      const Eigen::Quaterniond dq_gt = gi.q_w_x.conjugate() * gj.q_w_x;
      const Eigen::Vector3d d_est = qa[i].conjugate() * (pa[j] - pa[i]);
      const Eigen::Quaterniond dq_est = qa[i].conjugate() * qa[j];
      // E = dT_gt^-1 dT_est: translation dq_gt^-1 (d_est - d_gt), rotation dq_gt^-1 dq_est.
      ts.push_back((dq_gt.conjugate() * (d_est - d_gt)).norm());
      rs.push_back(angle_deg(dq_gt.conjugate() * dq_est));
    }
    out.translation_m = error_stats(ts);
    out.rotation_deg = error_stats(rs);
    return out;
  };
  for (double d : options.rpe_distances_m) r.rpe.push_back(rpe_for(d, RpeUnit::kMetres));
  for (double d : options.rpe_times_s) r.rpe.push_back(rpe_for(d, RpeUnit::kSeconds));
  return r;
}

}  // namespace ums::eval
