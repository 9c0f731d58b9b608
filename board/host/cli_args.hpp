#pragma once
// Command-line parsing for the umsvins subcommands: positionals and --name [value] options,
// every option declared, every mistake named ("umsvins replay: --duration needs a number, got 'x'").

#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <ostream>
#include <vector>

#include "board/config/app_config.hpp"

namespace ums::cli {

// Thrown for wrong usage; the message is ready for the user. main() maps it to exit 64.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class Args {
 public:
  // flags: options without a value (e.g. --realtime); valued: options taking one value.
  Args(std::string command, const std::vector<std::string>& argv, const std::set<std::string>& flags,
       const std::set<std::string>& valued);

  const std::vector<std::string>& positionals() const { return positionals_; }
  bool has(const std::string& name) const;
  std::optional<std::string> get(const std::string& name) const;
  std::string get_or(const std::string& name, const std::string& fallback) const;
  std::string require(const std::string& name) const;
  double get_double(const std::string& name, double fallback) const;
  long get_long(const std::string& name, long fallback) const;
  // "A:B" ranges, e.g. --start-range 0:40.
  std::pair<double, double> get_range(const std::string& name, std::pair<double, double> fallback) const;
  void require_positionals(std::size_t n, const char* what) const;

 private:
  std::string command_;
  std::vector<std::string> positionals_;
  std::map<std::string, std::string> values_;
  std::set<std::string> flags_set_;
};

// The configuration a command runs with: the --config file over the rig's calibration, or the
// calibration alone; the file's warnings go to err as "warning: ..." lines.
AppConfig config_of(const Args& args, const RigCalibration& rig, std::ostream& err);

}  // namespace ums::cli
