#include "board/host/mavlink_args.hpp"

#include <stdexcept>

#include "board/host/loop_session.hpp"
#include "board/host/replay_pipeline.hpp"
#include "hal/link/link_spec.hpp"

namespace ums::cli {

std::set<std::string> with_mavlink_flags(std::set<std::string> flags) {
  flags.insert({"mavlink-imu-rate", "mavlink-vision"});
  return flags;
}

std::set<std::string> with_mavlink_valued(std::set<std::string> valued) {
  valued.insert({"mavlink", "mavlink-rate", "mavlink-sysid"});
  return valued;
}

MavlinkSession::MavlinkSession(std::unique_ptr<hal::ByteLink> link, const MavlinkOutputOptions& options,
                               const std::filesystem::path& log_path)
    : link_(std::move(link)) {
  log_ = std::fopen(log_path.c_str(), "w");
  if (log_ == nullptr) throw std::runtime_error(log_path.string() + ": cannot open for writing");
  std::fputs(MavlinkOutput::log_header(), log_);
  MavlinkOutputOptions o = options;
  o.log = log_;
  output_ = std::make_unique<MavlinkOutput>(o, link_.get());
}

MavlinkSession::~MavlinkSession() { close(); }

bool MavlinkSession::close() {
  if (log_ == nullptr) return true;
  const bool ok = std::fclose(log_) == 0;
  log_ = nullptr;
  return ok;
}

std::unique_ptr<MavlinkSession> mavlink_from_args(const Args& args, const AppConfig& config,
                                                  const std::filesystem::path& out_dir) {
  const std::optional<std::string> spec = args.get("mavlink");
  if (!spec) {
    for (const char* o : {"mavlink-rate", "mavlink-sysid", "mavlink-imu-rate", "mavlink-vision"})
      if (args.has(o)) throw UsageError(std::string("--") + o + " needs --mavlink udp:HOST:PORT|serial:PATH[:BAUD]");
    return nullptr;
  }
  MavlinkOutputOptions options;
  options.rate_hz = args.get_double("mavlink-rate", options.rate_hz);
  const long sysid = args.get_long("mavlink-sysid", options.system_id);
  if (sysid < 1 || sysid > 255) throw UsageError("--mavlink-sysid must be 1..255, got " + std::to_string(sysid));
  options.system_id = static_cast<std::uint8_t>(sysid);
  options.imu_rate = args.has("mavlink-imu-rate");
  options.vision_messages = args.has("mavlink-vision");
  options.R_b_v = config.T_b_vehicle.linear();
  try {
    options.validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--mavlink-rate: ") + e.what());
  }
  std::unique_ptr<hal::ByteLink> link;
  try {
    link = hal::open_link(*spec);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--mavlink: ") + e.what());
  }
  std::filesystem::create_directories(out_dir);
  return std::make_unique<MavlinkSession>(std::move(link), options, out_dir / "mavlink_sent.csv");
}

void attach_mavlink(MavlinkSession* mavlink, LoopSession* loop, ReplayPipeline& pipeline) {
  if (mavlink == nullptr) return;
  pipeline.set_pose_consumer(loop != nullptr ? loop->map_frame(&mavlink->output()) : &mavlink->output());
}

void finish_mavlink(MavlinkSession* mavlink, ReplayPipeline& pipeline, JsonWriter& w,
                    const std::filesystem::path& out_dir, std::ostream& err) {
  if (mavlink == nullptr) return;
  pipeline.set_pose_consumer(nullptr);
  mavlink->output().write_stats(w);
  if (!mavlink->close()) err << "warning: " << (out_dir / "mavlink_sent.csv").string() << ": write failed\n";
}

}  // namespace ums::cli
