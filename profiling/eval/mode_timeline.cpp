#include "profiling/eval/mode_timeline.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace ums::eval {
namespace {

const std::string* find(const std::map<std::string, std::string>& m, const std::string& key) {
  const auto it = m.find(key);
  return it == m.end() ? nullptr : &it->second;
}

bool to_int64(const std::string& text, std::int64_t* v) {
  char* end = nullptr;
  const long long x = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0') return false;
  *v = static_cast<std::int64_t>(x);
  return true;
}

bool to_double(const std::string& text, double* v) {
  char* end = nullptr;
  *v = std::strtod(text.c_str(), &end);
  return !text.empty() && *end == '\0' && std::isfinite(*v);
}

}  // namespace

const std::string& ModeTimeline::mode_at(std::int64_t since_origin_ns) const {
  const std::string* mode = &initial_mode;
  for (const ModeEntry& c : changes) {
    if (c.since_origin_ns > since_origin_ns) break;
    mode = &c.mode;
  }
  return *mode;
}

bool mode_timeline_from_stats(const std::map<std::string, std::string>& stats, ModeTimeline* timeline,
                              std::string* error) {
  auto bad = [&](const std::string& m) {
    if (error != nullptr) *error = m;
    return false;
  };
  ModeTimeline t;
  if (const std::string* origin = find(stats, "first_frame_t_ns")) {
    if (!to_int64(*origin, &t.origin_t_ns)) return bad("first_frame_t_ns is not an integer: '" + *origin + "'");
    t.origin_known = true;
  }
  for (std::size_t i = 0;; ++i) {
    const std::string key = "modes." + std::to_string(i) + ".";
    const std::string* to = find(stats, key + "to");
    if (to == nullptr) break;
    const std::string* from = find(stats, key + "from");
    if (i == 0 && from != nullptr) t.initial_mode = *from;
    ModeEntry e;
    e.mode = *to;
    const std::string* t_ns = find(stats, key + "t_ns");
    const std::string* t_s = find(stats, key + "t_s");
    std::int64_t abs_ns = 0;
    double s = 0.0;
    if (t_ns != nullptr && t.origin_known && to_int64(*t_ns, &abs_ns)) {
      e.since_origin_ns = abs_ns - t.origin_t_ns;
    } else if (t_s != nullptr && to_double(*t_s, &s)) {
      e.since_origin_ns = static_cast<std::int64_t>(std::llround(s * 1e9));
    } else {
      return bad(key + "t_s is missing or not a number");
    }
    t.changes.push_back(e);
  }
  if (t.changes.empty()) {
    const std::string* mode = find(stats, "estimator.mode");
    if (mode == nullptr) return bad("no mode timeline (neither modes[] nor estimator.mode: a --frontend-only run?)");
    t.initial_mode = *mode;
  }
  std::stable_sort(t.changes.begin(), t.changes.end(),
                   [](const ModeEntry& a, const ModeEntry& b) { return a.since_origin_ns < b.since_origin_ns; });
  *timeline = t;
  return true;
}

}  // namespace ums::eval
