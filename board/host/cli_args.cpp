#include "board/host/cli_args.hpp"

#include <cerrno>
#include <cstdlib>

namespace ums::cli {

Args::Args(std::string command, const std::vector<std::string>& argv,
           const std::set<std::string>& flags, const std::set<std::string>& valued)
    : command_(std::move(command)) {
  for (std::size_t i = 0; i < argv.size(); ++i) {
    const std::string& a = argv[i];
    if (a.size() > 2 && a.compare(0, 2, "--") == 0) {
      std::string name = a.substr(2);
      std::string inline_value;
      bool has_inline = false;
      const std::size_t eq = name.find('=');
      if (eq != std::string::npos) {
        inline_value = name.substr(eq + 1);
        name = name.substr(0, eq);
        has_inline = true;
      }
      if (flags.count(name) != 0) {
        if (has_inline) throw UsageError("umsvins " + command_ + ": --" + name + " takes no value");
        flags_set_.insert(name);
      } else if (valued.count(name) != 0) {
        if (has_inline) {
          values_[name] = inline_value;
        } else {
          if (i + 1 >= argv.size()) throw UsageError("umsvins " + command_ + ": --" + name + " needs a value");
          values_[name] = argv[++i];
        }
      } else {
        throw UsageError("umsvins " + command_ + ": unknown option '" + a + "' (see umsvins help)");
      }
    } else {
      positionals_.push_back(a);
    }
  }
}

bool Args::has(const std::string& name) const {
  return flags_set_.count(name) != 0 || values_.count(name) != 0;
}

std::optional<std::string> Args::get(const std::string& name) const {
  const auto it = values_.find(name);
  if (it == values_.end()) return std::nullopt;
  return it->second;
}

std::string Args::get_or(const std::string& name, const std::string& fallback) const {
  return get(name).value_or(fallback);
}

std::string Args::require(const std::string& name) const {
  const auto v = get(name);
  if (!v) throw UsageError("umsvins " + command_ + ": --" + name + " is required");
  return *v;
}

double Args::get_double(const std::string& name, double fallback) const {
  const auto v = get(name);
  if (!v) return fallback;
  char* end = nullptr;
  errno = 0;
  const double d = std::strtod(v->c_str(), &end);
  if (v->empty() || *end != '\0' || errno != 0) {
    throw UsageError("umsvins " + command_ + ": --" + name + " needs a number, got '" + *v + "'");
  }
  return d;
}

long Args::get_long(const std::string& name, long fallback) const {
  const auto v = get(name);
  if (!v) return fallback;
  char* end = nullptr;
  errno = 0;
  const long n = std::strtol(v->c_str(), &end, 10);
  if (v->empty() || *end != '\0' || errno != 0) {
    throw UsageError("umsvins " + command_ + ": --" + name + " needs a whole number, got '" + *v + "'");
  }
  return n;
}

std::pair<double, double> Args::get_range(const std::string& name,
                                          std::pair<double, double> fallback) const {
  const auto v = get(name);
  if (!v) return fallback;
  const std::size_t colon = v->find(':');
  char* end_a = nullptr;
  char* end_b = nullptr;
  if (colon != std::string::npos) {
    const std::string a = v->substr(0, colon);
    const std::string b = v->substr(colon + 1);
    const double lo = std::strtod(a.c_str(), &end_a);
    const double hi = std::strtod(b.c_str(), &end_b);
    if (!a.empty() && !b.empty() && *end_a == '\0' && *end_b == '\0' && lo <= hi) return {lo, hi};
  }
  throw UsageError("umsvins " + command_ + ": --" + name + " needs A:B with A <= B, got '" + *v + "'");
}

void Args::require_positionals(std::size_t n, const char* what) const {
  if (positionals_.size() < n) throw UsageError("umsvins " + command_ + ": missing " + what);
  if (positionals_.size() > n) {
    throw UsageError("umsvins " + command_ + ": unexpected argument '" + positionals_[n] + "'");
  }
}

AppConfig config_of(const Args& args, const RigCalibration& rig, std::ostream& err) {
  std::vector<std::string> warnings;
  AppConfig config = args.get("config") ? load_config(*args.get("config"), rig, &warnings) : config_from_calibration(rig);
  for (const std::string& w : warnings) err << "warning: " << w << "\n";
  return config;
}

}  // namespace ums::cli
