#include "profiling/eval/report_html.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

namespace ums::eval {
namespace {

constexpr const char* kColorGt = "#222222";
constexpr const char* kColorEst = "#d62728";
const char* const kPalette[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2",
                                "#17becf", "#bcbd22"};

std::string esc(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '&': o += "&amp;"; break;
      case '"': o += "&quot;"; break;
      default: o += c;
    }
  }
  return o;
}

std::string num(double v, int decimals = 3) {
  char b[64];
  std::snprintf(b, sizeof b, "%.*f", decimals, v);
  return b;
}

struct Series {
  std::vector<double> x, y;
  std::string color;
  std::string label;
  bool step = false;  // draw as steps (counts per frame)
  bool pairs = false; // points 2i and 2i+1 joined by a line each (loops), not one polyline
};

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    if (!std::isfinite(v)) return;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  bool valid() const { return lo <= hi; }
  void pad() {
    if (!valid()) { lo = 0.0; hi = 1.0; }
    if (hi - lo < 1e-9) { lo -= 0.5; hi += 0.5; }
  }
};

// A "nice" tick step (1, 2, 5 x 10^k) giving about n ticks.
double tick_step(double span, int n) {
  const double raw = span / n;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  const double m = raw / p;
  return (m < 1.5 ? 1.0 : m < 3.5 ? 2.0 : m < 7.5 ? 5.0 : 10.0) * p;
}

int decimals_for(double step) {
  return std::max(0, std::min(6, static_cast<int>(-std::floor(std::log10(step) + 1e-9))));
}

// A shaded span of x behind the series (a mode phase, the worst window).
struct Band {
  double x0 = 0.0, x1 = 0.0;
  std::string fill;
  double opacity = 0.15;
  std::string label;       // written at the top of the band when it is wide enough
  bool outline = false;    // dashed outline in the fill colour (marks rather than shades)
};

std::string band_svg(const Band& b, double left_px, double right_px, double top_px, double height_px) {
  std::ostringstream o;
  o << "<rect x='" << num(left_px, 1) << "' y='" << num(top_px, 1) << "' width='" << num(right_px - left_px, 1)
    << "' height='" << num(height_px, 1) << "' fill='" << b.fill << "' fill-opacity='" << num(b.opacity, 2) << "'";
  if (b.outline) o << " stroke='" << b.fill << "' stroke-width='1.5' stroke-dasharray='5,3'";
  o << "><title>" << esc(b.label) << "</title></rect>";
  if (!b.label.empty() && right_px - left_px > 7.0 * static_cast<double>(b.label.size())) {
    // Mode names at the top, the marked window's label at the bottom (errors peak upwards).
    o << "<text x='" << num(left_px + 3, 1) << "' y='" << num(b.outline ? top_px + height_px - 5 : top_px + 11, 1)
      << "' font-size='10' fill='" << (b.outline ? b.fill : "#555") << "'>" << esc(b.label) << "</text>";
  }
  return o.str();
}

// An SVG line chart with axes, ticks, labels and a legend. equal_aspect keeps metres square.
std::string line_chart(const std::string& title, const std::string& xlabel, const std::string& ylabel,
                       const std::vector<Series>& series, bool equal_aspect, int w = 560, int h = 360,
                       const std::vector<Band>& bands = {}) {
  const double ml = 62, mr = 14, mt = 28, mb = 44;
  const double pw = w - ml - mr, ph = h - mt - mb;
  Range rx, ry;
  for (const auto& s : series) {
    for (double v : s.x) rx.add(v);
    for (double v : s.y) ry.add(v);
  }
  rx.pad();
  ry.pad();
  if (equal_aspect) {
    const double sx = (rx.hi - rx.lo) / pw, sy = (ry.hi - ry.lo) / ph;
    const double s = std::max(sx, sy) * 1.05;
    const double cx = 0.5 * (rx.lo + rx.hi), cy = 0.5 * (ry.lo + ry.hi);
    rx.lo = cx - 0.5 * s * pw; rx.hi = cx + 0.5 * s * pw;
    ry.lo = cy - 0.5 * s * ph; ry.hi = cy + 0.5 * s * ph;
  } else {
    const double py = 0.05 * (ry.hi - ry.lo);
    ry.lo -= py; ry.hi += py;
  }
  auto X = [&](double v) { return ml + (v - rx.lo) / (rx.hi - rx.lo) * pw; };
  auto Y = [&](double v) { return mt + ph - (v - ry.lo) / (ry.hi - ry.lo) * ph; };
  std::ostringstream o;
  o << "<svg xmlns='http://www.w3.org/2000/svg' width='" << w << "' height='" << h << "' viewBox='0 0 " << w
    << ' ' << h << "'>";
  o << "<rect x='0' y='0' width='" << w << "' height='" << h << "' fill='#fff'/>";
  o << "<text x='" << w / 2 << "' y='18' text-anchor='middle' font-size='14' font-weight='bold'>" << esc(title)
    << "</text>";
  o << "<rect x='" << ml << "' y='" << mt << "' width='" << pw << "' height='" << ph
    << "' fill='#fafafa' stroke='#888'/>";
  for (const Band& b : bands) {
    const double left = X(std::max(b.x0, rx.lo)), right = X(std::min(b.x1, rx.hi));
    if (right > left) o << band_svg(b, left, right, mt, ph);
  }
  const double stx = tick_step(rx.hi - rx.lo, 6), sty = tick_step(ry.hi - ry.lo, 5);
  for (double v = std::ceil(rx.lo / stx) * stx; v <= rx.hi + 1e-12; v += stx) {
    o << "<line x1='" << num(X(v), 1) << "' y1='" << mt << "' x2='" << num(X(v), 1) << "' y2='" << mt + ph
      << "' stroke='#e4e4e4'/><text x='" << num(X(v), 1) << "' y='" << mt + ph + 15
      << "' text-anchor='middle' font-size='11'>" << num(std::abs(v) < 1e-12 ? 0.0 : v, decimals_for(stx))
      << "</text>";
  }
  for (double v = std::ceil(ry.lo / sty) * sty; v <= ry.hi + 1e-12; v += sty) {
    o << "<line x1='" << ml << "' y1='" << num(Y(v), 1) << "' x2='" << ml + pw << "' y2='" << num(Y(v), 1)
      << "' stroke='#e4e4e4'/><text x='" << ml - 5 << "' y='" << num(Y(v) + 4, 1)
      << "' text-anchor='end' font-size='11'>" << num(std::abs(v) < 1e-12 ? 0.0 : v, decimals_for(sty))
      << "</text>";
  }
  o << "<text x='" << ml + pw / 2 << "' y='" << h - 8 << "' text-anchor='middle' font-size='12'>" << esc(xlabel)
    << "</text>";
  o << "<text transform='translate(14," << mt + ph / 2 << ") rotate(-90)' text-anchor='middle' font-size='12'>"
    << esc(ylabel) << "</text>";
  int legend_y = mt + 14;
  for (const auto& s : series) {
    const std::size_t n = std::min(s.x.size(), s.y.size());
    if (n == 0) continue;
    // Thin long series so a 3-minute run stays a few hundred kB.
    const std::size_t stride = std::max<std::size_t>(1, n / 3000);
    if (s.pairs) {
      for (std::size_t i = 0; i + 1 < n; i += 2) {
        o << "<line x1='" << num(X(s.x[i]), 1) << "' y1='" << num(Y(s.y[i]), 1) << "' x2='" << num(X(s.x[i + 1]), 1)
          << "' y2='" << num(Y(s.y[i + 1]), 1) << "' stroke='" << s.color << "' stroke-width='1.2'/>"
          << "<circle cx='" << num(X(s.x[i]), 1) << "' cy='" << num(Y(s.y[i]), 1) << "' r='2.5' fill='" << s.color
          << "'/>";
      }
    } else {
    o << "<polyline fill='none' stroke='" << s.color << "' stroke-width='1.4' points='";
    double prev_y = 0.0;
    for (std::size_t i = 0; i < n; i += stride) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      if (s.step && i > 0) o << num(X(s.x[i]), 1) << ',' << num(Y(prev_y), 1) << ' ';
      o << num(X(s.x[i]), 1) << ',' << num(Y(s.y[i]), 1) << ' ';
      prev_y = s.y[i];
    }
    o << "'/>";
    }
    if (!s.label.empty()) {
      o << "<line x1='" << ml + pw - 120 << "' y1='" << legend_y - 4 << "' x2='" << ml + pw - 100 << "' y2='"
        << legend_y - 4 << "' stroke='" << s.color << "' stroke-width='3'/><text x='" << ml + pw - 95 << "' y='"
        << legend_y << "' font-size='11'>" << esc(s.label) << "</text>";
      legend_y += 15;
    }
  }
  o << "</svg>";
  return o.str();
}

std::string histogram(const ReportStageTiming& st, const char* color) {
  const int w = 360, h = 240;
  const double ml = 48, mr = 10, mt = 28, mb = 40;
  const double pw = w - ml - mr, ph = h - mt - mb;
  std::vector<double> v;
  for (double x : st.ms) if (std::isfinite(x)) v.push_back(x);
  std::ostringstream o;
  o << "<svg xmlns='http://www.w3.org/2000/svg' width='" << w << "' height='" << h << "'>";
  o << "<rect width='" << w << "' height='" << h << "' fill='#fff'/>";
  std::sort(v.begin(), v.end());
  const double median = v.empty() ? 0.0 : v[v.size() / 2];
  const double p99 = v.empty() ? 0.0 : v[std::min(v.size() - 1, static_cast<std::size_t>(0.99 * static_cast<double>(v.size())))];
  o << "<text x='" << w / 2 << "' y='18' text-anchor='middle' font-size='13' font-weight='bold'>" << esc(st.name)
    << " [ms]: median " << num(median, 2) << ", p99 " << num(p99, 2) << "</text>";
  o << "<rect x='" << ml << "' y='" << mt << "' width='" << pw << "' height='" << ph
    << "' fill='#fafafa' stroke='#888'/>";
  if (!v.empty()) {
    const int bins = 30;
    const double lo = v.front(), hi = std::max(v.back(), v.front() + 1e-6) * 1.0001;
    std::vector<int> count(bins, 0);
    for (double x : v) count[std::min(bins - 1, static_cast<int>((x - lo) / (hi - lo) * bins))]++;
    const int cmax = *std::max_element(count.begin(), count.end());
    for (int b = 0; b < bins; ++b) {
      const double bh = ph * count[b] / std::max(1, cmax);
      o << "<rect x='" << num(ml + pw * b / bins, 1) << "' y='" << num(mt + ph - bh, 1) << "' width='"
        << num(pw / bins - 1, 1) << "' height='" << num(bh, 1) << "' fill='" << color << "'/>";
    }
    o << "<text x='" << ml << "' y='" << mt + ph + 15 << "' font-size='11'>" << num(lo, 2) << "</text><text x='" << ml + pw
      << "' y='" << mt + ph + 15 << "' text-anchor='end' font-size='11'>" << num(hi, 2) << "</text>";
    o << "<text x='" << ml - 4 << "' y='" << mt + 10 << "' text-anchor='end' font-size='11'>" << cmax << "</text>";
  }
  o << "<text x='" << ml + pw / 2 << "' y='" << h - 8 << "' text-anchor='middle' font-size='12'>ms per frame ("
    << v.size() << " frames)</text></svg>";
  return o.str();
}

const char* mode_color(const std::string& mode) {
  if (mode == "VIO") return "#2ca02c";
  if (mode == "VO") return "#1f77b4";
  if (mode == "IMU_ONLY") return "#ff7f0e";
  if (mode == "VISION_LOST") return "#8c564b";
  if (mode == "INIT" || mode == "INITIALIZING") return "#9e9e9e";
  if (mode == "LOST" || mode == "FAILED") return "#d62728";
  unsigned hsh = 0;
  for (char c : mode) hsh = hsh * 31u + static_cast<unsigned char>(c);
  return kPalette[hsh % 8];
}

std::string mode_timeline(const std::vector<ReportModeChange>& modes, double end_t_s) {
  const int w = 1120, h = 90;
  const double ml = 20, mr = 20, mt = 26, bh = 30;
  const double pw = w - ml - mr;
  std::ostringstream o;
  o << "<svg xmlns='http://www.w3.org/2000/svg' width='" << w << "' height='" << h << "'>";
  o << "<rect width='" << w << "' height='" << h << "' fill='#fff'/>";
  o << "<text x='" << w / 2 << "' y='16' text-anchor='middle' font-size='14' font-weight='bold'>Mode timeline</text>";
  if (modes.empty()) {
    o << "<text x='" << ml << "' y='" << mt + 20 << "' font-size='12'>no mode changes recorded</text></svg>";
    return o.str();
  }
  const double t0 = modes.front().t_s;
  const double t1 = std::max(end_t_s, modes.back().t_s + 1e-3);
  auto X = [&](double t) { return ml + (t - t0) / (t1 - t0) * pw; };
  for (std::size_t i = 0; i < modes.size(); ++i) {
    const double a = modes[i].t_s, b = i + 1 < modes.size() ? modes[i + 1].t_s : t1;
    o << "<rect x='" << num(X(a), 1) << "' y='" << mt << "' width='" << num(std::max(0.5, X(b) - X(a)), 1)
      << "' height='" << bh << "' fill='" << mode_color(modes[i].mode) << "'><title>" << esc(modes[i].mode) << ' '
      << num(a, 2) << "-" << num(b, 2) << " s</title></rect>";
    if (X(b) - X(a) > 40) {
      o << "<text x='" << num(X(a) + 4, 1) << "' y='" << mt + 20 << "' font-size='12' fill='#fff'>"
        << esc(modes[i].mode) << "</text>";
    }
  }
  o << "<text x='" << ml << "' y='" << mt + bh + 16 << "' font-size='11'>" << num(t0, 1)
    << " s</text><text x='" << ml + pw << "' y='" << mt + bh + 16 << "' text-anchor='end' font-size='11'>"
    << num(t1, 1) << " s</text></svg>";
  return o.str();
}

// Position error over time, each mode phase shaded in its timeline colour, the worst window
// outlined in red.
std::string budget_chart(const ReportBudget& b, const std::vector<ReportModeChange>& modes, double end_t_s) {
  std::vector<Band> bands;
  for (std::size_t i = 0; i < modes.size(); ++i) {
    const double t1 = i + 1 < modes.size() ? modes[i + 1].t_s : std::max(end_t_s, b.t_s.empty() ? 0.0 : b.t_s.back());
    bands.push_back({modes[i].t_s, t1, mode_color(modes[i].mode), 0.15, modes[i].mode, false});
  }
  if (b.has_worst) {
    bands.push_back({b.worst_start_s, b.worst_end_s, kColorEst, 0.12,
                     "worst " + num(b.worst_end_s - b.worst_start_s, 0) + " s: " + num(b.worst_rmse_m, 4) + " m", true});
  }
  std::vector<Series> s;
  s.push_back({b.t_s, b.error_m, kColorEst, "|p_gt - align(p_est)|", false});
  return line_chart("Error budget: position error by mode", "t [s] since the first frame", "error [m]", s, false,
                    740, 360, bands);
}

std::string budget_table(const ReportBudget& b) {
  std::ostringstream o;
  o << "<table><tr><td><b>mode</b></td><td><b>poses</b></td><td><b>time [s]</b></td>"
       "<td><b>ATE RMSE [m]</b></td><td><b>share of ATE&sup2; [%]</b></td></tr>";
  for (const ReportBudgetPhase& p : b.phases) {
    o << "<tr><td>" << esc(p.mode) << "</td><td>" << p.poses << "</td><td>" << num(p.duration_s, 2) << "</td><td>"
      << (std::isfinite(p.ate_rmse_m) ? num(p.ate_rmse_m, 4) : std::string("-")) << "</td><td>"
      << num(p.share_pct, 1) << "</td></tr>";
  }
  if (b.phases.empty()) o << "<tr><td colspan='5'>no per-mode split (no mode timeline)</td></tr>";
  o << "</table><table style='margin-top:8px'>";
  for (const auto& kv : b.figures) o << "<tr><td>" << esc(kv.first) << "</td><td>" << esc(kv.second) << "</td></tr>";
  o << "</table>";
  return o.str();
}

std::vector<double> component(const ReportPositions& p, int axis) {
  std::vector<double> v;
  v.reserve(p.p_w_m.size());
  for (const auto& x : p.p_w_m) v.push_back(x[axis]);
  return v;
}

std::vector<double> to_double(const std::vector<int>& v) { return std::vector<double>(v.begin(), v.end()); }

// The loops as pairs of points (query keyframe first) for the top view.
Series loop_pairs(const std::vector<ReportLoop>& loops) {
  Series s;
  s.color = kPalette[2];
  s.label = "loops (" + std::to_string(loops.size()) + ")";
  s.pairs = true;
  for (const ReportLoop& l : loops) {
    s.x.insert(s.x.end(), {l.p_query_m.x(), l.p_loop_m.x()});
    s.y.insert(s.y.end(), {l.p_query_m.y(), l.p_loop_m.y()});
  }
  return s;
}

std::string loop_table(const std::vector<ReportLoop>& loops) {
  std::ostringstream o;
  o << "<h2>Loops</h2><table><tr><td>t [s]</td><td>query - loop [m]</td><td>inliers</td><td>correction [m]</td>"
       "<td>correction [deg]</td><td>kind</td></tr>";
  const std::size_t shown = std::min<std::size_t>(loops.size(), 200);
  for (std::size_t i = 0; i < shown; ++i) {
    const ReportLoop& l = loops[i];
    o << "<tr><td>" << num(l.t_s, 2) << "</td><td>" << num((l.p_query_m - l.p_loop_m).norm(), 3) << "</td><td>"
      << l.inliers << "</td><td>" << num(l.correction_m, 4) << "</td><td>" << num(l.correction_deg, 3) << "</td><td>"
      << (l.relocalization ? "relocalization" : "loop") << "</td></tr>";
  }
  o << "</table>";
  if (shown < loops.size()) o << "<p>" << loops.size() - shown << " more in loops.csv</p>";
  return o.str() + "\n";
}

}  // namespace

std::string render_report_html(const ReportData& d) {
  std::ostringstream o;
  o << "<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>" << esc(d.title) << "</title>\n"
    << "<style>body{font-family:sans-serif;margin:16px;background:#fff;color:#111}"
       "h1{font-size:20px}h2{font-size:16px;margin:18px 0 6px}table{border-collapse:collapse}"
       "td{border:1px solid #ccc;padding:3px 8px;font-size:13px}.row{display:flex;flex-wrap:wrap;gap:8px}"
       "</style></head><body>\n";
  o << "<h1>" << esc(d.title) << "</h1>\n";
  if (!d.summary.empty()) {
    o << "<table>";
    for (const auto& kv : d.summary) o << "<tr><td>" << esc(kv.first) << "</td><td>" << esc(kv.second) << "</td></tr>";
    o << "</table>\n";
  }
  o << "<h2>Trajectory</h2><div class='row'>";
  {
    std::vector<Series> s;
    if (!d.groundtruth.p_w_m.empty()) s.push_back({component(d.groundtruth, 0), component(d.groundtruth, 1), kColorGt, "ground truth", false});
    if (!d.estimate.p_w_m.empty()) s.push_back({component(d.estimate, 0), component(d.estimate, 1), kColorEst, "estimate", false});
    if (!d.map_estimate.p_w_m.empty()) {
      s.push_back({component(d.map_estimate, 0), component(d.map_estimate, 1), kPalette[0], "final map (loops)", false});
    }
    if (!d.loops.empty()) s.push_back(loop_pairs(d.loops));
    o << line_chart("Top view (x-y)", "x [m]", "y [m]", s, true);
  }
  {
    std::vector<Series> s;
    s.push_back({d.error_t_s, d.error_m, kColorEst, "|p_est - p_gt|", false});
    o << line_chart("Position error over time", "t [s]", "error [m]", s, false);
  }
  o << "</div><div class='row'>";
  const char* axes[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    std::vector<Series> s;
    if (!d.groundtruth.p_w_m.empty()) s.push_back({d.groundtruth.t_s, component(d.groundtruth, a), kColorGt, "ground truth", false});
    if (!d.estimate.p_w_m.empty()) s.push_back({d.estimate.t_s, component(d.estimate, a), kColorEst, "estimate", false});
    o << line_chart(std::string(axes[a]) + " over time", "t [s]", std::string(axes[a]) + " [m]", s, false, 370, 260);
  }
  o << "</div>\n";
  if (!d.loops.empty()) o << loop_table(d.loops);
  if (d.budget.present) {
    o << "<h2>Error budget</h2><div class='row'>" << budget_chart(d.budget, d.modes, d.end_t_s) << "<div>"
      << budget_table(d.budget) << "</div></div>\n";
  }
  if (d.time_offset.present) {
    const ReportTimeOffset& td = d.time_offset;
    std::vector<Series> s;
    if (!td.t_s.empty())
      s.push_back({{td.t_s.front(), td.t_s.back()}, {td.calibration_ms, td.calibration_ms}, kColorGt, "calibration", false});
    s.push_back({td.t_s, td.td_ms, kColorEst, "estimate", false});
    o << "<h2>Camera-IMU time offset</h2><div class='row'>"
      << line_chart("td over time (t_imu = t_cam + td)", "t [s]", "td [ms]", s, false, 1120, 300) << "</div>\n";
  }
  o << "<h2>Timing per stage</h2><div class='row'>";
  for (std::size_t i = 0; i < d.stage_timings.size(); ++i) o << histogram(d.stage_timings[i], kPalette[i % 8]);
  if (d.stage_timings.empty()) o << "<p>no timing recorded</p>";
  o << "</div>\n<h2>Features per frame</h2><div class='row'>";
  {
    std::vector<Series> s;
    s.push_back({d.features.t_s, to_double(d.features.n_3d), kPalette[2], "3D (stereo)", true});
    s.push_back({d.features.t_s, to_double(d.features.n_2d_left), kPalette[0], "2D left", true});
    s.push_back({d.features.t_s, to_double(d.features.n_2d_right), kPalette[1], "2D right", true});
    o << line_chart("Features per frame by class", "t [s]", "features", s, false, 1120, 300);
  }
  o << "</div>\n<h2>Modes</h2>" << mode_timeline(d.modes, d.end_t_s) << "\n</body></html>\n";
  return o.str();
}

bool write_report_html(const ReportData& data, const std::string& path, std::string* error) {
  std::ofstream f(path, std::ios::binary);
  if (!f) {
    if (error != nullptr) *error = path + ": cannot open for writing";
    return false;
  }
  f << render_report_html(data);
  f.close();
  if (!f) {
    if (error != nullptr) *error = path + ": write failed";
    return false;
  }
  return true;
}

}  // namespace ums::eval
