#include "profiling/eval/trajectory.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace ums::eval {
namespace {

std::vector<std::string> split(const std::string& line, bool comma) {
  std::vector<std::string> out;
  if (comma) {
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) out.push_back(cell);
  } else {
    std::stringstream ss(line);
    std::string cell;
    while (ss >> cell) out.push_back(cell);
  }
  return out;
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

[[noreturn]] void fail(const std::string& path, int line, const std::string& what) {
  throw std::runtime_error(path + ":" + std::to_string(line) + ": " + what);
}

double to_double(const std::string& path, int line, const std::string& cell) {
  char* end = nullptr;
  const std::string t = trim(cell);
  const double v = std::strtod(t.c_str(), &end);
  if (t.empty() || end == t.c_str()) fail(path, line, "not a number: '" + t + "'");
  return v;
}

// Nanosecond stamps like "1403715274312143104.0000000000": the integer part, exactly.
std::int64_t to_ns(const std::string& path, int line, const std::string& cell) {
  const std::string t = trim(cell);
  char* end = nullptr;
  const long long v = std::strtoll(t.c_str(), &end, 10);
  if (t.empty() || end == t.c_str()) fail(path, line, "not a timestamp: '" + t + "'");
  return static_cast<std::int64_t>(v);
}

// Whole seconds as nanoseconds; a time whose nanoseconds do not fit int64 (beyond ~292 years,
// no trajectory stamp) is refused rather than overflowing (found by tests/fuzz/trajectory_fuzz).
std::int64_t whole_seconds_to_ns(const std::string& path, int line, const std::string& cell, std::int64_t whole) {
  constexpr std::int64_t kMaxWholeS = std::numeric_limits<std::int64_t>::max() / 1000000000LL - 1;
  if (whole > kMaxWholeS || whole < -kMaxWholeS) fail(path, line, "time out of range: '" + trim(cell) + "' s");
  return whole * 1000000000LL;
}

// Seconds with up to nanosecond decimals, parsed without going through a double.
std::int64_t seconds_to_ns(const std::string& path, int line, const std::string& cell) {
  const std::string t = trim(cell);
  const auto dot = t.find('.');
  if (dot == std::string::npos) return whole_seconds_to_ns(path, line, t, to_ns(path, line, t));
  const std::int64_t whole_ns =
      whole_seconds_to_ns(path, line, t, dot == 0 ? 0 : to_ns(path, line, t.substr(0, dot)));
  std::string frac = t.substr(dot + 1);
  frac.erase(std::remove_if(frac.begin(), frac.end(), [](char c) { return c < '0' || c > '9'; }),
             frac.end());
  frac = frac.substr(0, 9);
  while (frac.size() < 9) frac.push_back('0');
  const std::int64_t f = std::strtoll(frac.c_str(), nullptr, 10);
  const bool negative = !t.empty() && t[0] == '-';
  return negative ? whole_ns - f : whole_ns + f;
}

struct Rows {
  std::vector<std::vector<std::string>> cells;
  std::vector<int> line_numbers;
};

Rows read_rows(const std::string& path, bool comma) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  Rows rows;
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#' || t[0] == '%') continue;
    rows.cells.push_back(split(t, comma));
    rows.line_numbers.push_back(n);
  }
  return rows;
}

void finish(const std::string& path, Trajectory& traj) {
  std::stable_sort(traj.poses.begin(), traj.poses.end(),
                   [](const StampedPose& a, const StampedPose& b) { return a.t_ns < b.t_ns; });
  // Duplicate stamps would make association ambiguous: keep the first.
  traj.poses.erase(std::unique(traj.poses.begin(), traj.poses.end(),
                               [](const StampedPose& a, const StampedPose& b) { return a.t_ns == b.t_ns; }),
                   traj.poses.end());
  if (traj.poses.empty()) throw std::runtime_error(path + ": no poses");
}

}  // namespace

Trajectory read_tum(const std::string& path) {
  const Rows rows = read_rows(path, false);
  Trajectory traj;
  traj.frame = PoseFrame::kBody;
  for (std::size_t i = 0; i < rows.cells.size(); ++i) {
    const auto& c = rows.cells[i];
    const int ln = rows.line_numbers[i];
    if (c.size() < 8) fail(path, ln, "TUM needs 8 columns (t x y z qx qy qz qw), got " + std::to_string(c.size()));
    StampedPose p;
    p.t_ns = seconds_to_ns(path, ln, c[0]);
    p.p_w_x = {to_double(path, ln, c[1]), to_double(path, ln, c[2]), to_double(path, ln, c[3])};
    p.q_w_x = Eigen::Quaterniond(to_double(path, ln, c[7]), to_double(path, ln, c[4]),
                                 to_double(path, ln, c[5]), to_double(path, ln, c[6]));
    if (p.q_w_x.norm() < 1e-6) fail(path, ln, "zero quaternion");
    p.q_w_x.normalize();
    traj.poses.push_back(p);
  }
  finish(path, traj);
  return traj;
}

Trajectory read_euroc_csv(const std::string& path) {
  const Rows rows = read_rows(path, true);
  Trajectory traj;
  traj.frame = PoseFrame::kBody;
  for (std::size_t i = 0; i < rows.cells.size(); ++i) {
    const auto& c = rows.cells[i];
    const int ln = rows.line_numbers[i];
    if (c.size() < 8) fail(path, ln, "EuRoC ground truth needs >= 8 columns, got " + std::to_string(c.size()));
    StampedPose p;
    p.t_ns = to_ns(path, ln, c[0]);
    p.p_w_x = {to_double(path, ln, c[1]), to_double(path, ln, c[2]), to_double(path, ln, c[3])};
    // EuRoC stores q_RS (body -> world) as w, x, y, z.
    p.q_w_x = Eigen::Quaterniond(to_double(path, ln, c[4]), to_double(path, ln, c[5]),
                                 to_double(path, ln, c[6]), to_double(path, ln, c[7]));
    if (p.q_w_x.norm() < 1e-6) fail(path, ln, "zero quaternion");
    p.q_w_x.normalize();
    traj.poses.push_back(p);
  }
  finish(path, traj);
  return traj;
}

Trajectory read_shared_gt(const std::string& path) {
  Trajectory traj = read_euroc_csv(path);
  // The shared files store q = R_CW (world -> camera): the camera's attitude is its inverse.
  for (auto& p : traj.poses) p.q_w_x = p.q_w_x.conjugate();
  traj.frame = PoseFrame::kCam0;
  return traj;
}

Trajectory read_trajectory(const std::string& path, TrajectoryFormat format) {
  if (format == TrajectoryFormat::kTum) return read_tum(path);
  if (format == TrajectoryFormat::kEurocCsv) return read_euroc_csv(path);
  if (format == TrajectoryFormat::kSharedGt) return read_shared_gt(path);
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::string line;
  while (std::getline(in, line)) {
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#' || t[0] == '%') continue;
    if (t.find(',') != std::string::npos) {
      const std::size_t cols = split(t, true).size();
      if (cols == 8) return read_shared_gt(path);
      if (cols >= 17) return read_euroc_csv(path);
      throw std::runtime_error(path + ": cannot tell the format from a row of " + std::to_string(cols) +
                               " comma-separated columns (8: shared GT, >= 17: EuRoC)");
    }
    return read_tum(path);
  }
  throw std::runtime_error(path + ": empty");
}

void write_tum(const std::string& path, const Trajectory& trajectory) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) throw std::runtime_error(path + ": cannot write");
  for (const auto& p : trajectory.poses) {
    const long long s = p.t_ns / 1000000000LL;
    const long long ns = p.t_ns % 1000000000LL;
    std::fprintf(f, "%lld.%09lld %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", s, ns, p.p_w_x.x(), p.p_w_x.y(),
                 p.p_w_x.z(), p.q_w_x.x(), p.q_w_x.y(), p.q_w_x.z(), p.q_w_x.w());
  }
  if (std::fclose(f) != 0) throw std::runtime_error(path + ": write failed");
}

Trajectory change_frame(const Trajectory& in, const Eigen::Isometry3d& T_x_y, PoseFrame out_frame) {
  Trajectory out;
  out.frame = out_frame;
  out.poses.reserve(in.poses.size());
  const Eigen::Quaterniond q_x_y(T_x_y.rotation());
  for (const auto& p : in.poses) {
    StampedPose o;
    o.t_ns = p.t_ns;
    o.p_w_x = p.p_w_x + p.q_w_x * T_x_y.translation();
    o.q_w_x = (p.q_w_x * q_x_y).normalized();
    out.poses.push_back(o);
  }
  return out;
}

Trajectory to_frame(const Trajectory& in, PoseFrame frame, const Eigen::Isometry3d& T_b_c0) {
  if (in.frame == frame) return in;
  return frame == PoseFrame::kCam0 ? change_frame(in, T_b_c0, PoseFrame::kCam0)
                                   : change_frame(in, T_b_c0.inverse(), PoseFrame::kBody);
}

Eigen::Isometry3d euroc_T_b_c0() {
  Eigen::Matrix4d m;
  m << 0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,
      0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,
      -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,
      0.0, 0.0, 0.0, 1.0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  // Re-orthonormalize: the published matrix is orthogonal to ~1e-9 only.
  T.linear() = Eigen::Quaterniond(m.block<3, 3>(0, 0)).normalized().toRotationMatrix();
  T.translation() = m.block<3, 1>(0, 3);
  return T;
}

Eigen::Isometry3d read_T_BS(const std::string& sensor_yaml_path) {
  std::ifstream in(sensor_yaml_path);
  if (!in) throw std::runtime_error(sensor_yaml_path + ": cannot open");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  const auto key = text.find("T_BS");
  if (key == std::string::npos) throw std::runtime_error(sensor_yaml_path + ": no T_BS key");
  const auto data = text.find("data:", key);
  const auto open = text.find('[', data);
  const auto close = text.find(']', open);
  if (data == std::string::npos || open == std::string::npos || close == std::string::npos)
    throw std::runtime_error(sensor_yaml_path + ": T_BS has no data: [...] list");
  std::string list = text.substr(open + 1, close - open - 1);
  std::replace(list.begin(), list.end(), ',', ' ');
  std::stringstream ls(list);
  Eigen::Matrix4d m;
  for (int i = 0; i < 16; ++i) {
    if (!(ls >> m(i / 4, i % 4)))
      throw std::runtime_error(sensor_yaml_path + ": T_BS data needs 16 numbers, got " + std::to_string(i));
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(m.block<3, 3>(0, 0)).normalized().toRotationMatrix();
  T.translation() = m.block<3, 1>(0, 3);
  return T;
}

}  // namespace ums::eval
