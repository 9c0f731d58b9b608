#pragma once
// `replay --fault KIND:START_S:DURATION_S[:PARAM][,...]` (hal/replay/fault_injection.hpp) and
// `--fault-seed N` (frame-drop's draws, default 1): the injector between the dataset and the
// pipeline, and what it did in stats.json "faults".

#include <memory>
#include <string>

#include "board/host/cli_args.hpp"
#include "hal/replay/fault_injection.hpp"
#include "profiling/json_writer.hpp"

namespace ums::cli {

// nullptr without --fault; UsageError on a malformed list.
std::unique_ptr<hal::FaultInjector> faults_from_args(const Args& args, MeasurementSink* pipeline);
void write_fault_stats(const std::string& spec, const hal::FaultCounters& c, JsonWriter& w);

}  // namespace ums::cli
