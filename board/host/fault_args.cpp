#include "board/host/fault_args.hpp"

#include <sstream>

namespace ums::cli {

std::unique_ptr<hal::FaultInjector> faults_from_args(const Args& args, MeasurementSink* pipeline) {
  if (!args.get("fault")) {
    if (args.has("fault-seed")) throw UsageError("--fault-seed needs --fault");
    return nullptr;
  }
  hal::Fault faults[hal::FaultInjector::kMaxFaults];
  int n = 0;
  std::istringstream in(*args.get("fault"));
  for (std::string spec; std::getline(in, spec, ',');) {
    if (n == hal::FaultInjector::kMaxFaults) throw UsageError("--fault: at most 16 faults");
    std::string error;
    if (!hal::parse_fault(spec, &faults[n++], &error)) throw UsageError("--fault: " + error);
  }
  if (n == 0) throw UsageError("--fault: empty list");
  const double seed = args.get_double("fault-seed", 1.0);
  if (!(seed >= 0.0 && seed < 1e15)) throw UsageError("--fault-seed: a non-negative integer");
  return std::make_unique<hal::FaultInjector>(faults, n, static_cast<std::uint64_t>(seed), pipeline);
}

void write_fault_stats(const std::string& spec, const hal::FaultCounters& c, JsonWriter& w) {
  w.begin_object("faults")
      .value("spec", spec)
      .value("imu_lost", c.imu_lost)
      .value("imu_corrupted", c.imu_corrupted)
      .value("imu_extra", c.imu_extra)
      .value("imu_reordered", c.imu_reordered)
      .value("frames_lost", c.frames_lost)
      .value("frames_altered", c.frames_altered)
      .value("frames_extra", c.frames_extra)
      .value("restamped", c.restamped)
      .end_object();
}

}  // namespace ums::cli
