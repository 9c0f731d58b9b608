#pragma once
// The front end's and the estimator's options from the configuration file (board/config): one
// mapping for every program that builds the pipeline (replay, the memory budget), so that a key
// the file accepts reaches the part it configures everywhere.

#include "board/config/app_config.hpp"
#include "core/estimator/estimator.hpp"
#include "core/frontend/frontend.hpp"

namespace ums::cli {

FrontendOptions frontend_options_from(const AppConfig& config);
// deterministic: the second BA round bounded by its iteration cap only, not by
// config.max_solver_time_s (the same trajectory on any machine, however loaded or emulated).
EstimatorOptions estimator_options_from(const AppConfig& config, bool deterministic);

}  // namespace ums::cli
