#pragma once
// The umsvins subcommands as functions, so tests run them in-process. Exit codes:
// 0 success, 1 failure (bad input, I/O), 2 capability not implemented yet, 64 wrong usage.

#include <ostream>
#include <string>
#include <vector>

namespace ums::cli {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;
inline constexpr int kExitNotImplemented = 2;
inline constexpr int kExitUsage = 64;

// args excludes the program name: {"replay", "<dataset>", "--out", "DIR"}.
int run_cli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

int run_replay(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int run_sweep(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int run_simulate(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int run_eval(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int run_record(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int run_live(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int run_budget(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int run_vocab(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace ums::cli
