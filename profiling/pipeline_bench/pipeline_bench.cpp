// Pipeline benchmark: the whole pipeline (front end, estimator, poses) on a recording whose frames
// are decoded into memory first, so that the figures are the pipeline's and not libpng's: frames
// per second pushed as fast as the pipeline takes them, and the latency of each frame (arrival to
// its pose), with the estimator on the caller's thread (one core) and on a second thread
// (--two-core, board/host/backend_thread.hpp). Both runs use --deterministic's solver bound, and
// their poses must be equal bit for bit (the two-core option's contract).
// Usage: umsvins_bench_pipeline <dataset_dir> [repeats (3)] [max_frames (400)]
// Each mode runs `repeats` times, alternating; the best wall time counts (the machine is shared).
// Last line: one JSON object.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "board/host/backend_thread.hpp"
#include "core/common/calibration.hpp"
#include "core/imu/imu_noise.hpp"
#include "core/pipeline/vio_pipeline.hpp"
#include "hal/replay/euroc_reader.hpp"

namespace {

// The recording in push order, images decoded and owned.
struct Recording {
  struct Event {
    bool is_frame = false;
    ums::ImuSample imu;
    std::int64_t t_ns = 0;
    std::size_t image = 0;  // index of the left image in pixels (right follows)
  };
  ums::RigCalibration rig;
  int width = 0, height = 0;
  std::vector<Event> events;
  std::vector<std::vector<std::uint8_t>> pixels;
  std::size_t frames = 0;
};

std::vector<std::uint8_t> copy_view(const ums::ImageView& v) {
  std::vector<std::uint8_t> out(static_cast<std::size_t>(v.width) * static_cast<std::size_t>(v.height));
  for (int y = 0; y < v.height; ++y) std::memcpy(out.data() + static_cast<std::size_t>(y) * v.width, v.row(y), v.width);
  return out;
}

Recording load(const std::string& dir, std::size_t max_frames) {
  ums::hal::EurocReader reader;
  reader.open(dir);
  Recording rec;
  rec.rig = reader.calibration();
  ums::ImuSample imu;
  ums::StereoFrame frame;
  for (;;) {
    const auto ev = reader.next(&imu, &frame);
    if (ev == ums::hal::EurocReader::Event::kEnd) break;
    Recording::Event e;
    if (ev == ums::hal::EurocReader::Event::kImu) {
      e.imu = imu;
      rec.events.push_back(e);
      continue;
    }
    if (rec.frames == max_frames) break;
    if (!frame.left.valid() || !frame.right.valid()) continue;
    e.is_frame = true;
    e.t_ns = frame.t_ns;
    e.image = rec.pixels.size();
    rec.width = frame.left.width;
    rec.height = frame.left.height;
    rec.pixels.push_back(copy_view(frame.left));
    rec.pixels.push_back(copy_view(frame.right));
    rec.events.push_back(e);
    ++rec.frames;
  }
  if (rec.frames < 20) throw std::runtime_error("pipeline_bench: " + dir + ": fewer than 20 stereo pairs");
  return rec;
}

// Collects the poses (to compare the modes) and each frame's latency.
struct Collector final : ums::PoseSink, ums::FrameObserver {
  void on_frame_pose(const ums::EstimatorOutput& out) override {
    poses.push_back({static_cast<double>(out.t_ns), out.p_w_b.x(), out.p_w_b.y(), out.p_w_b.z(), out.q_w_b.x(),
                     out.q_w_b.y(), out.q_w_b.z(), out.q_w_b.w()});
  }
  void on_imu_pose(std::int64_t, const ums::NavState&) override {}
  void on_frame_done(const ums::VioFrameRecord& r, const ums::StereoFrame&) override {
    latency_ms.push_back(r.total_ms);
    frontend_ms.push_back(r.frontend_ms);
    if (r.estimated) backend_ms.push_back(static_cast<double>(r.timing.backend_ms));
  }
  std::vector<std::vector<double>> poses;
  std::vector<double> latency_ms, frontend_ms, backend_ms;
};

struct RunResult {
  double wall_s = 0.0;
  Collector collected;
};

RunResult run(const Recording& rec, bool two_core) {
  ums::EstimatorOptions eo;
  eo.focal_px = rec.rig.cam[0].fx;
  eo.keyframe.focal_px = static_cast<float>(eo.focal_px);
  eo.preintegration.noise = ums::ImuNoise::from_calibration(rec.rig.imu);
  eo.round2_time_s = std::numeric_limits<double>::infinity();  // --deterministic: iterations bound the solve
  std::unique_ptr<ums::cli::BackendThread> backend(two_core ? new ums::cli::BackendThread() : nullptr);
  ums::VioPipeline pipeline(ums::VioPipelineOptions(), ums::FrontendOptions(), eo, rec.rig);
  RunResult result;
  result.collected.poses.reserve(rec.frames);
  for (auto* v : {&result.collected.latency_ms, &result.collected.frontend_ms, &result.collected.backend_ms}) v->reserve(rec.frames);
  pipeline.set_pose_sink(&result.collected);
  pipeline.set_frame_observer(&result.collected);
  pipeline.set_backend_executor(backend.get());
  const auto start = std::chrono::steady_clock::now();
  for (const Recording::Event& e : rec.events) {
    if (!e.is_frame) {
      pipeline.on_imu(e.imu);
      continue;
    }
    ums::StereoFrame f;
    f.t_ns = e.t_ns;
    f.left = ums::ImageView{rec.pixels[e.image].data(), rec.width, rec.height, rec.width};
    f.right = ums::ImageView{rec.pixels[e.image + 1].data(), rec.width, rec.height, rec.width};
    pipeline.on_stereo(f);
  }
  pipeline.flush();
  result.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  pipeline.set_backend_executor(nullptr);
  return result;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5)];
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: umsvins_bench_pipeline <dataset_dir> [repeats (3)] [max_frames (400)]\n");
    return 64;
  }
  const int repeats = argc > 2 ? std::max(1, std::stoi(argv[2])) : 3;
  const std::size_t max_frames = argc > 3 ? static_cast<std::size_t>(std::stoul(argv[3])) : 400;
  try {
    const Recording rec = load(argv[1], max_frames);
    RunResult best[2];
    for (int r = 0; r < repeats; ++r) {
      for (int mode = 0; mode < 2; ++mode) {
        RunResult res = run(rec, mode == 1);
        std::fprintf(stderr, "pipeline_bench: %s run %d: %.3f s\n", mode ? "two-core" : "one-core", r + 1, res.wall_s);
        if (r == 0 || res.wall_s < best[mode].wall_s) best[mode] = std::move(res);
      }
    }
    const bool same = best[0].collected.poses == best[1].collected.poses;
    const double n = static_cast<double>(rec.frames);
    std::printf("%-9s %9s %12s %12s %12s %12s\n", "mode", "frames/s", "latency p50", "latency p99", "front p50", "back p50");
    for (int mode = 0; mode < 2; ++mode) {
      const Collector& c = best[mode].collected;
      std::printf("%-9s %9.1f %9.2f ms %9.2f ms %9.2f ms %9.2f ms\n", mode ? "two-core" : "one-core", n / best[mode].wall_s,
                  percentile(c.latency_ms, 0.5), percentile(c.latency_ms, 0.99), percentile(c.frontend_ms, 0.5),
                  percentile(c.backend_ms, 0.5));
    }
    std::printf("poses: %zu, two-core equal to one-core bit for bit: %s\n", best[0].collected.poses.size(), same ? "yes" : "NO");
    std::printf("{\"frames\": %zu, \"width\": %d, \"height\": %d, \"repeats\": %d, \"same_poses\": %s", rec.frames, rec.width,
                rec.height, repeats, same ? "true" : "false");
    for (int mode = 0; mode < 2; ++mode) {
      const Collector& c = best[mode].collected;
      std::printf(", \"%s\": {\"fps\": %.2f, \"wall_s\": %.4f, \"latency_p50_ms\": %.3f, \"latency_p99_ms\": %.3f}",
                  mode ? "two_core" : "one_core", n / best[mode].wall_s, best[mode].wall_s, percentile(c.latency_ms, 0.5),
                  percentile(c.latency_ms, 0.99));
    }
    std::printf("}\n");
    return same ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pipeline_bench: %s\n", e.what());
    return 1;
  }
}
