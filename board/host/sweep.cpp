#include "board/host/sweep.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <random>
#include <sstream>
#include <stdexcept>

#include "profiling/eval/metrics.hpp"
#include "profiling/json_writer.hpp"

namespace ums::cli {
namespace {

namespace fs = std::filesystem;

// Recursive-descent reader of the JSON our own tools write (stats.json): enough of RFC 8259 to
// read any well-formed document; \u escapes above ASCII are kept as '?' (no key we read has them).
class JsonFlattener {
 public:
  explicit JsonFlattener(const std::string& text) : s_(text) {}

  std::map<std::string, std::string> run() {
    skip_ws();
    parse_value("");
    skip_ws();
    if (i_ != s_.size()) fail("text after the document");
    return std::move(out_);
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error("JSON at byte " + std::to_string(i_) + ": " + what);
  }
  void skip_ws() {
    while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\t' || s_[i_] == '\n' || s_[i_] == '\r')) ++i_;
  }
  char peek() const { return i_ < s_.size() ? s_[i_] : '\0'; }
  void expect(char c) {
    if (peek() != c) fail(std::string("expected '") + c + "'");
    ++i_;
  }
  static std::string join(const std::string& prefix, const std::string& key) {
    return prefix.empty() ? key : prefix + "." + key;
  }

  std::string parse_string() {
    expect('"');
    std::string v;
    while (true) {
      if (i_ >= s_.size()) fail("unterminated string");
      const char c = s_[i_++];
      if (c == '"') return v;
      if (c != '\\') {
        v += c;
        continue;
      }
      if (i_ >= s_.size()) fail("unterminated escape");
      const char e = s_[i_++];
      switch (e) {
        case '"': v += '"'; break;
        case '\\': v += '\\'; break;
        case '/': v += '/'; break;
        case 'b': v += '\b'; break;
        case 'f': v += '\f'; break;
        case 'n': v += '\n'; break;
        case 'r': v += '\r'; break;
        case 't': v += '\t'; break;
        case 'u': {
          if (i_ + 4 > s_.size()) fail("short \\u escape");
          const unsigned long code = std::strtoul(s_.substr(i_, 4).c_str(), nullptr, 16);
          i_ += 4;
          v += code < 0x80 ? static_cast<char>(code) : '?';
          break;
        }
        default: fail(std::string("bad escape '\\") + e + "'");
      }
    }
  }

  void parse_value(const std::string& path) {
    skip_ws();
    const char c = peek();
    if (c == '{') {
      ++i_;
      skip_ws();
      if (peek() == '}') {
        ++i_;
        return;
      }
      while (true) {
        skip_ws();
        const std::string key = parse_string();
        skip_ws();
        expect(':');
        parse_value(join(path, key));
        skip_ws();
        if (peek() == ',') {
          ++i_;
          continue;
        }
        expect('}');
        return;
      }
    }
    if (c == '[') {
      ++i_;
      skip_ws();
      if (peek() == ']') {
        ++i_;
        return;
      }
      for (std::size_t index = 0;; ++index) {
        parse_value(join(path, std::to_string(index)));
        skip_ws();
        if (peek() == ',') {
          ++i_;
          continue;
        }
        expect(']');
        return;
      }
    }
    if (c == '"') {
      out_[path] = parse_string();
      return;
    }
    // Literal or number: up to the next delimiter.
    const std::size_t begin = i_;
    while (i_ < s_.size() && s_[i_] != ',' && s_[i_] != '}' && s_[i_] != ']' && s_[i_] != ' ' &&
           s_[i_] != '\n' && s_[i_] != '\r' && s_[i_] != '\t') {
      ++i_;
    }
    const std::string token = s_.substr(begin, i_ - begin);
    if (token.empty()) fail("expected a value");
    if (token != "true" && token != "false" && token != "null") {
      char* end = nullptr;
      std::strtod(token.c_str(), &end);
      if (end != token.c_str() + token.size()) fail("not a value: '" + token + "'");
    }
    out_[path] = token;
  }

  const std::string& s_;
  std::size_t i_ = 0;
  std::map<std::string, std::string> out_;
};

std::string read_text(const fs::path& path) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error(path.string() + ": cannot open");
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

}  // namespace

bool SweepOptions::validate(std::string* error) const {
  if (dataset.empty()) {
    *error = "missing <dataset> (the folder holding mav0/)";
    return false;
  }
  if (out_dir.empty()) {
    *error = "--out is required";
    return false;
  }
  if (runs < 1) {
    *error = "--runs must be >= 1, got " + std::to_string(runs);
    return false;
  }
  if (!std::isfinite(start_min_s) || !std::isfinite(start_max_s) || start_min_s < 0.0 ||
      start_min_s > start_max_s) {
    *error = "--start-range needs 0 <= A <= B (seconds), got " + fixed(start_min_s, 3) + ":" +
             fixed(start_max_s, 3);
    return false;
  }
  if (!std::isfinite(duration_s) || duration_s < 0.0) {
    *error = "--duration must be >= 0 s (0 = to the end), got " + fixed(duration_s, 3);
    return false;
  }
  if (!(min_pose_fraction > 0.0 && min_pose_fraction <= 1.0)) {
    *error = "min_pose_fraction must be in (0, 1], got " + fixed(min_pose_fraction, 3);
    return false;
  }
  return true;
}

std::vector<double> draw_start_times(int n, double a_s, double b_s, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<double> out;
  out.reserve(static_cast<std::size_t>(n > 0 ? n : 0));
  for (int k = 0; k < n; ++k) {
    // The top 53 bits as a fraction in [0, 1]: std::uniform_real_distribution is implementation
    // defined, this is the same on every standard library (host and board give the same table).
    const double u = static_cast<double>(rng() >> 11) / 9007199254740991.0;  // 2^53 - 1
    out.push_back(a_s + u * (b_s - a_s));
  }
  return out;
}

std::map<std::string, std::string> flatten_json(const std::string& text) {
  return JsonFlattener(text).run();
}

SweepRun score_run(int run, double start_s, const RunOutcome& outcome, const std::string& run_dir,
                   const eval::Trajectory& groundtruth, double min_pose_fraction) {
  SweepRun r;
  r.run = run;
  r.start_s = start_s;
  std::vector<std::string> reasons;
  if (outcome.exit_code != 0) {
    reasons.push_back("replay exited with code " + std::to_string(outcome.exit_code) +
                      (outcome.message.empty() ? "" : " (" + outcome.message + ")"));
  }

  // stats.json: the frames the run processed and whether it initialized.
  const fs::path stats_path = fs::path(run_dir) / "stats.json";
  if (!fs::exists(stats_path)) {
    reasons.push_back("no stats.json");
  } else {
    try {
      const std::map<std::string, std::string> stats = flatten_json(read_text(stats_path));
      const auto frames = stats.find("frames");
      if (frames != stats.end()) r.frames = std::atol(frames->second.c_str());
      const auto init = stats.find("init.success");
      if (init == stats.end()) {
        reasons.push_back("stats.json has no init.success");
      } else if (init->second == "true") {
        r.init_success = true;
      } else {
        reasons.push_back("initialization failed");
      }
    } catch (const std::exception& e) {
      reasons.push_back(stats_path.string() + ": " + e.what());
    }
  }

  // trajectory.tum: enough poses, then the ATE.
  const fs::path tum_path = fs::path(run_dir) / "trajectory.tum";
  if (!fs::exists(tum_path)) {
    reasons.push_back("no trajectory.tum");
  } else {
    try {
      const eval::Trajectory estimate = eval::read_tum(tum_path.string());
      r.poses = static_cast<long>(estimate.poses.size());
      if (r.frames < 0) {
        reasons.push_back("stats.json has no frame count: the pose share cannot be checked");
      } else if (r.frames == 0) {
        reasons.push_back("replay processed no frames");
      } else if (static_cast<double>(r.poses) < min_pose_fraction * static_cast<double>(r.frames)) {
        reasons.push_back("poses for " + std::to_string(r.poses) + " of " + std::to_string(r.frames) +
                          " frames (" + fixed(100.0 * static_cast<double>(r.poses) / static_cast<double>(r.frames), 1) +
                          "%, need " + fixed(100.0 * min_pose_fraction, 0) + "%)");
      }
      eval::MetricsOptions metrics;
      metrics.align = eval::AlignMode::kSe3;
      metrics.rpe_distances_m.clear();  // the table needs the ATE only
      metrics.rpe_times_s.clear();
      r.rmse_m = eval::evaluate(estimate, groundtruth, metrics).ate.translation_m.rmse;
    } catch (const std::exception& e) {
      reasons.push_back(std::string("ATE not computed: ") + e.what());
    }
  }

  for (std::size_t i = 0; i < reasons.size(); ++i) r.reason += (i == 0 ? "" : "; ") + reasons[i];
  r.success = reasons.empty();
  return r;
}

SweepSummary summarize(const std::vector<SweepRun>& runs) {
  SweepSummary s;
  s.runs = static_cast<int>(runs.size());
  double sum = 0.0;
  int n = 0;
  for (const SweepRun& r : runs) {
    if (!r.success) {
      ++s.failures;
      continue;
    }
    sum += r.rmse_m;
    ++n;
  }
  if (n == 0) return s;
  s.rmse_mean_m = sum / n;
  double sq = 0.0;
  for (const SweepRun& r : runs) {
    if (r.success) sq += (r.rmse_m - s.rmse_mean_m) * (r.rmse_m - s.rmse_mean_m);
  }
  // Sample (n - 1) standard deviation: the runs are a sample of the start times one could pick.
  s.rmse_std_m = n > 1 ? std::sqrt(sq / (n - 1)) : 0.0;
  return s;
}

SweepResult run_sweep_loop(const SweepOptions& options, const eval::Trajectory& groundtruth,
                           const SweepRunner& runner, std::ostream& progress) {
  std::string error;
  if (!options.validate(&error)) throw std::invalid_argument("sweep: " + error);
  fs::create_directories(options.out_dir);
  const std::vector<double> starts =
      draw_start_times(options.runs, options.start_min_s, options.start_max_s, options.seed);
  SweepResult result;
  for (int k = 1; k <= options.runs; ++k) {
    const double start_s = starts[static_cast<std::size_t>(k - 1)];
    const fs::path run_dir = fs::path(options.out_dir) / ("run_" + std::to_string(k));
    // A previous sweep's files must not score this run: start from an empty folder.
    fs::remove_all(run_dir);
    fs::create_directories(run_dir);
    progress << "sweep: run " << k << "/" << options.runs << " from " << fixed(start_s, 3) << " s ... "
             << std::flush;
    RunOutcome outcome;
    try {
      outcome = runner(start_s, run_dir.string());
    } catch (const std::exception& e) {
      outcome.exit_code = 1;
      outcome.message = e.what();
    }
    SweepRun r = score_run(k, start_s, outcome, run_dir.string(), groundtruth, options.min_pose_fraction);
    if (r.success) {
      progress << "ok, ATE RMSE " << fixed(r.rmse_m, 4) << " m\n";
    } else {
      progress << "FAILED: " << r.reason << "\n";
    }
    result.runs.push_back(std::move(r));
  }
  result.summary = summarize(result.runs);
  return result;
}

std::string sweep_json(const SweepOptions& options, const SweepResult& result) {
  JsonWriter w;
  w.begin_object();
  w.value("dataset", options.dataset);
  w.value("seed", static_cast<std::uint64_t>(options.seed));
  w.begin_array("start_range_s").element(options.start_min_s).element(options.start_max_s).end_array();
  w.value("duration_s", options.duration_s);
  w.value("min_pose_fraction", options.min_pose_fraction);
  w.begin_array("runs");
  for (const SweepRun& r : result.runs) {
    w.begin_object();
    w.value("run", r.run);
    w.value("start_s", r.start_s, 9);
    if (r.rmse_m >= 0.0) {
      w.value("rmse_m", r.rmse_m);
    } else {
      w.null("rmse_m");
    }
    w.value("success", r.success);
    if (r.success) {
      w.null("reason");
    } else {
      w.value("reason", r.reason);
    }
    w.value("frames", static_cast<std::int64_t>(r.frames));
    w.value("poses", static_cast<std::int64_t>(r.poses));
    w.value("init_success", r.init_success);
    w.end_object();
  }
  w.end_array();
  const SweepSummary& s = result.summary;
  w.begin_object("summary");
  w.value("runs", s.runs);
  w.value("failures", s.failures);
  if (s.rmse_mean_m >= 0.0) {
    w.value("rmse_mean", s.rmse_mean_m);
    w.value("rmse_std", s.rmse_std_m);
  } else {
    w.null("rmse_mean");
    w.null("rmse_std");
  }
  w.value("std", "sample (n - 1) over successful runs, m");
  w.end_object();
  w.end_object();
  return w.str();
}

void print_sweep_table(const SweepResult& result, std::ostream& out) {
  char line[256];
  std::snprintf(line, sizeof line, "%4s  %9s  %9s  %s", "run", "start [s]", "RMSE [m]", "status");
  out << line << "\n";
  for (const SweepRun& r : result.runs) {
    const std::string rmse = r.rmse_m >= 0.0 ? fixed(r.rmse_m, 4) : "-";
    std::snprintf(line, sizeof line, "%4d  %9.3f  %9s  ", r.run, r.start_s, rmse.c_str());
    out << line << (r.success ? "ok" : "FAILED: " + r.reason) << "\n";
  }
  const SweepSummary& s = result.summary;
  out << "sweep: " << s.runs << " runs, " << s.failures << " failed";
  if (s.rmse_mean_m >= 0.0) {
    out << "; ATE RMSE (SE(3)) over " << (s.runs - s.failures) << " successful runs: mean "
        << fixed(s.rmse_mean_m, 4) << " m, std " << fixed(s.rmse_std_m, 4) << " m (sample, n - 1)\n";
  } else {
    out << "; no successful run, no RMSE statistics\n";
  }
}

std::string sweep_groundtruth_path(const std::string& dataset) {
  return (fs::path(dataset) / "mav0" / "state_groundtruth_estimate0" / "data.csv").string();
}

}  // namespace ums::cli
