#pragma once
// The estimator's mode timeline as eval reads it back from a replay's stats.json: which mode
// (IMU_ONLY, VO, VIO) produced the pose at each time. Plain data; the JSON itself is parsed at the
// edge (board/host) and handed over flattened ("modes.0.to" -> "VO"). Tool code: allocates freely.

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace ums::eval {

struct ModeEntry {
  std::int64_t since_origin_ns = 0;  // ns after the timeline's origin (the run's first frame)
  std::string mode;                  // mode entered at that instant
};

struct ModeTimeline {
  // Absolute stamp (dataset clock, same as trajectory.tum) of the origin. stats.json written
  // before first_frame_t_ns existed lacks it: then the evaluation takes the first estimate pose.
  bool origin_known = false;
  std::int64_t origin_t_ns = 0;        // ns
  std::string initial_mode = "IMU_ONLY";
  std::vector<ModeEntry> changes;      // sorted by since_origin_ns

  // Mode in force at since_origin_ns. A pose stamped exactly at a change counts in the new mode:
  // the estimator switches while it processes that frame and outputs the frame's pose after.
  const std::string& mode_at(std::int64_t since_origin_ns) const;
};

// Builds the timeline from a flattened stats.json: modes.<i>.{t_s, from, to} (and, when present,
// modes.<i>.t_ns and first_frame_t_ns: exact; t_s alone has 4 significant digits). With no change
// recorded the whole run is in estimator.mode. False with *error when the keys are not there or
// not understood.
bool mode_timeline_from_stats(const std::map<std::string, std::string>& stats, ModeTimeline* timeline,
                              std::string* error);

}  // namespace ums::eval
