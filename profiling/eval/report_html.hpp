#pragma once
// One self-contained report.html (inline SVG and CSS, no script, no network) of a replay run:
// top view and x/y/z over time of estimate vs ground truth, position error over time, the error
// budget, per-stage timing histograms, features per frame by class, mode timeline. The caller
// (replay) fills the plain series below; nothing here knows the estimator. Tool code: allocates
// freely.

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace ums::eval {

struct ReportPositions {
  std::vector<double> t_s;            // s, same length as p_w_m
  std::vector<Eigen::Vector3d> p_w_m; // m, world frame (the estimate already aligned to the GT)
};

struct ReportStageTiming {
  std::string name;                   // "frontend", "backend", ...
  std::vector<double> ms;             // one duration per frame, ms
};

struct ReportFeatureCounts {
  std::vector<double> t_s;            // s, one entry per frame
  std::vector<int> n_3d;              // stereo features (triangulated by the stereo pair)
  std::vector<int> n_2d_left;         // left-only features
  std::vector<int> n_2d_right;        // right-only features
};

struct ReportModeChange {
  double t_s = 0.0;                   // s, start of this mode
  std::string mode;                   // "IMU_ONLY", "VO", "VIO", "INIT", ...
};

struct ReportBudgetPhase {
  std::string mode;                   // "IMU_ONLY", "VO", "VIO", ...
  std::size_t poses = 0;
  double duration_s = 0.0;            // s
  double ate_rmse_m = 0.0;            // m (NaN: no pose in this mode)
  double share_pct = 0.0;             // % of ATE^2
};

// The error budget (profiling/eval/error_budget.hpp) as the report shows it: the error over time
// with the mode phases (ReportData::modes) shaded and the worst window marked, and a table.
struct ReportBudget {
  bool present = false;
  std::vector<double> t_s;            // s, on the clock of ReportData::modes (the run's first frame)
  std::vector<double> error_m;        // m, per matched pose under the global SE(3)
  std::vector<ReportBudgetPhase> phases;  // empty: no per-mode split
  std::vector<std::pair<std::string, std::string>> figures;  // label, value with its unit
  bool has_worst = false;
  double worst_start_s = 0.0, worst_end_s = 0.0;  // s
  double worst_rmse_m = 0.0;          // m
  std::string worst_mode;
};

// An accepted loop (loop closure): the two keyframes' positions in the map frame after it closed.
struct ReportLoop {
  double t_s = 0.0;                   // s, the query keyframe, on the first-frame clock
  Eigen::Vector3d p_query_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_loop_m = Eigen::Vector3d::Zero();
  int inliers = 0;
  double correction_m = 0.0, correction_deg = 0.0;
  bool relocalization = false;
};

// The camera-IMU time offset over the run (estimate_td): the estimate per frame with a pose and
// the calibration's value it started from.
struct ReportTimeOffset {
  bool present = false;
  std::vector<double> t_s;            // s, on the clock of ReportData::modes
  std::vector<double> td_ms;          // ms, t_imu = t_cam + td
  double calibration_ms = 0.0;        // ms
};

struct ReportData {
  std::string title = "UMS-VINS run";
  std::vector<std::pair<std::string, std::string>> summary;  // key/value table at the top
  ReportPositions estimate;
  ReportPositions groundtruth;        // may be empty (no ground truth)
  // Loop closure (may be empty): the map-frame trajectory (aligned like the estimate) and the
  // accepted loops, drawn on the top view and listed.
  ReportPositions map_estimate;
  std::vector<ReportLoop> loops;
  std::vector<double> error_t_s;      // s; ATE per matched pose (may be empty)
  std::vector<double> error_m;        // m
  std::vector<ReportStageTiming> stage_timings;
  ReportFeatureCounts features;
  std::vector<ReportModeChange> modes;  // sorted by t_s
  double end_t_s = 0.0;               // s, end of the run (closes the last mode span)
  ReportBudget budget;                // section shown only when present
  ReportTimeOffset time_offset;       // section shown only when present
};

// The whole document as a string.
std::string render_report_html(const ReportData& data);

// Writes render_report_html(data) to path; false with *error set on I/O failure.
bool write_report_html(const ReportData& data, const std::string& path, std::string* error);

}  // namespace ums::eval
