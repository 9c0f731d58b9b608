#pragma once
// Outcome of solver calls. The solver lives below core/ and cannot use ums::Status, so it has its
// own enum; the estimator maps it (kInvalidInput -> Status::kInvalidInput, etc.).

#include <cstdint>

namespace ums::solver {

enum class SolverStatus : std::uint8_t {
  kOk = 0,            // set-up call succeeded
  kConverged,         // a cost, step, gradient or trust-region tolerance was met
  kMaxIterations,     // stopped on SolverOptions::max_iterations or max_successful_steps
  kTimeBudget,        // stopped on SolverOptions::max_time_s
  kInvalidInput,      // NaN/Inf in a parameter or residual, bad id, wrong size, bad structure
  kFull,              // a compile-time capacity of solver/capacity.hpp would be exceeded
  kNumericalFailure,  // too many consecutive invalid steps, or a non-finite Jacobian mid-solve
  kSingular,          // a marginalized block has no information
};

constexpr const char* to_string(SolverStatus s) {
  switch (s) {
    case SolverStatus::kOk: return "ok";
    case SolverStatus::kConverged: return "converged";
    case SolverStatus::kMaxIterations: return "max iterations";
    case SolverStatus::kTimeBudget: return "time budget";
    case SolverStatus::kInvalidInput: return "invalid input";
    case SolverStatus::kFull: return "capacity exceeded";
    case SolverStatus::kNumericalFailure: return "numerical failure";
    case SolverStatus::kSingular: return "singular";
  }
  return "unknown";
}

// A finished solve whose state is usable (converged or stopped on a bound).
constexpr bool usable(SolverStatus s) {
  return s == SolverStatus::kConverged || s == SolverStatus::kMaxIterations ||
         s == SolverStatus::kTimeBudget;
}

}  // namespace ums::solver
