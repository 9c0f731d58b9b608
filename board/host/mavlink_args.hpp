#pragma once
// The MAVLink options shared by `replay` and `live`: --mavlink udp:HOST:PORT|serial:PATH[:BAUD],
// --mavlink-rate HZ (30), --mavlink-sysid N (1), --mavlink-imu-rate, --mavlink-vision. The link,
// the output and its log (OUT/mavlink_sent.csv: every ODOMETRY, sent or dropped) live together.

#include <cstdio>
#include <filesystem>
#include <memory>
#include <ostream>
#include <set>
#include <string>

#include "board/config/app_config.hpp"
#include "board/host/cli_args.hpp"
#include "board/host/mavlink_output.hpp"
#include "hal/link/byte_link.hpp"
#include "profiling/json_writer.hpp"

namespace ums::cli {

// A command's own options plus the MAVLink ones.
std::set<std::string> with_mavlink_flags(std::set<std::string> flags);
std::set<std::string> with_mavlink_valued(std::set<std::string> valued);

class MavlinkSession {
 public:
  MavlinkSession(std::unique_ptr<hal::ByteLink> link, const MavlinkOutputOptions& options,
                 const std::filesystem::path& log_path);
  ~MavlinkSession();
  MavlinkSession(const MavlinkSession&) = delete;
  MavlinkSession& operator=(const MavlinkSession&) = delete;
  MavlinkOutput& output() { return *output_; }
  // Closes the log; false when writing it failed.
  bool close();

 private:
  std::unique_ptr<hal::ByteLink> link_;
  std::FILE* log_ = nullptr;
  std::unique_ptr<MavlinkOutput> output_;
};

// nullptr without --mavlink. Throws UsageError on a malformed option, std::runtime_error when
// the link cannot be opened.
std::unique_ptr<MavlinkSession> mavlink_from_args(const Args& args, const AppConfig& config,
                                                  const std::filesystem::path& out_dir);

class LoopSession;
class ReplayPipeline;

// The pipeline's poses to the link (nothing without one); with loop closure in the map frame, a
// reset (or a ramp) at each correction.
void attach_mavlink(MavlinkSession* mavlink, LoopSession* loop, ReplayPipeline& pipeline);
// At the end of a run: detaches the link, writes stats.json's "mavlink" and closes the log (a
// warning on err when writing it failed). Nothing without a link.
void finish_mavlink(MavlinkSession* mavlink, ReplayPipeline& pipeline, JsonWriter& w,
                    const std::filesystem::path& out_dir, std::ostream& err);

}  // namespace ums::cli
