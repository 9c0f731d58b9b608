// Front-end benchmark: ms per stereo frame on the EuRoC micro sequence at its native 752x480 and
// resampled to 848x480 (the D455 IR mode; calibration scaled to match), in two regimes:
//   steady: frames in order (tracking + top-up detection + stereo of every feature);
//   cold:   reset() before every frame (full detection and stereo search every frame: the upper
//           bound a scene cut or fast motion costs).
// Per regime also the sub-stage times the front end measures itself (FrontendFrameStats::pyramid_ms,
// detect_ms, track_ms, stereo_ms, ransac_ms) and an output hash over all steady features (equal
// hashes = bit-identical features, e.g. before and after a speed change).
// Usage: umsvins_bench_frontend [dataset_dir] [repeats]. Last line: one JSON object.

#include <algorithm>
#include <chrono>
#include <cstring>
#include <ctime>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/frontend/frontend.hpp"
#include "hal/replay/euroc_sensor_yaml.hpp"
#include "hal/replay/png_io.hpp"
#include "profiling/alloc_counter.hpp"

namespace {

struct Sequence {
  int width = 0, height = 0;
  std::vector<std::vector<std::uint8_t>> left, right;
};

Sequence load(const std::string& dir) {
  const std::string mav = dir + "/mav0";
  std::ifstream csv(mav + "/cam0/data.csv");
  if (!csv) throw std::runtime_error("cannot open " + mav + "/cam0/data.csv");
  Sequence s;
  std::string line;
  while (std::getline(csv, line)) {
    if (line.empty() || line[0] == '#') continue;
    const std::size_t comma = line.find(',');
    if (comma == std::string::npos) continue;
    std::string name = line.substr(comma + 1);
    while (!name.empty() && (name.back() == '\r' || name.back() == ' ')) name.pop_back();
    int w = 0, h = 0;
    if (!ums::hal::read_png_size((mav + "/cam0/data/" + name).c_str(), &w, &h)) continue;
    std::vector<std::uint8_t> l(static_cast<std::size_t>(w) * h), r(l.size());
    std::string err;
    int w1 = 0, h1 = 0;
    if (!ums::hal::read_png_gray8(mav + "/cam0/data/" + name, l.data(), l.size(), &w, &h, &err)) continue;
    if (!ums::hal::read_png_gray8(mav + "/cam1/data/" + name, r.data(), r.size(), &w1, &h1, &err) || w1 != w || h1 != h) continue;
    s.width = w;
    s.height = h;
    s.left.push_back(std::move(l));
    s.right.push_back(std::move(r));
  }
  if (s.left.empty()) throw std::runtime_error("no stereo pairs under " + mav);
  return s;
}

// Horizontal bilinear resampling to new_width (a stand-in for a wider sensor).
std::vector<std::uint8_t> resample_width(const std::vector<std::uint8_t>& src, int w, int h, int new_width) {
  std::vector<std::uint8_t> dst(static_cast<std::size_t>(new_width) * h);
  const double sx = static_cast<double>(w) / new_width;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < new_width; ++x) {
      const double u = std::max(0.0, (x + 0.5) * sx - 0.5);
      const int x0 = std::min(static_cast<int>(u), w - 2);
      const double a = u - x0;
      const double v = (1 - a) * src[static_cast<std::size_t>(y) * w + x0] + a * src[static_cast<std::size_t>(y) * w + x0 + 1];
      dst[static_cast<std::size_t>(y) * new_width + x] = static_cast<std::uint8_t>(v + 0.5);
    }
  }
  return dst;
}

double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

struct Result {
  double median_ms = 0, p99_ms = 0, max_ms = 0, mean_ms = 0;
  double cpu_mean_ms = 0;  // thread CPU time per frame: robust to a loaded machine
  double cold_median_ms = 0, cold_max_ms = 0;
  double mean_3d = 0, mean_2d = 0;
  unsigned long long allocs_after_first = 0;
  std::uint64_t output_hash = 0;  // FNV-1a over every feature of every steady frame (ids, classes, pixels)
  // Sub-stages (FrontendFrameStats::*_ms, in kStageNames order): steady median and mean, cold median.
  double stage_median_ms[5] = {}, stage_mean_ms[5] = {}, stage_cold_median_ms[5] = {};
};

constexpr const char* kStageNames[5] = {"pyramid", "detect", "track", "stereo", "ransac"};

void stage_times(const ums::FrontendFrameStats& st, double* out) {
  out[0] = static_cast<double>(st.pyramid_ms);
  out[1] = static_cast<double>(st.detect_ms);
  out[2] = static_cast<double>(st.track_ms);
  out[3] = static_cast<double>(st.stereo_ms);
  out[4] = static_cast<double>(st.ransac_ms);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// FNV-1a over the bytes of a value: the fingerprint that shows a change left the features bit-identical.
template <typename T>
void fnv1a(std::uint64_t* h, const T& v) {
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, &v, sizeof(T));
  for (unsigned char b : bytes) *h = (*h ^ b) * 1099511628211ull;
}

void hash_features(std::uint64_t* h, const ums::FrameFeatures& f) {
  for (const ums::FeatureObservation& o : f.features) {
    fnv1a(h, o.id);
    fnv1a(h, static_cast<std::uint8_t>(o.cls));
    fnv1a(h, o.track_length);
    fnv1a(h, o.uv_left_px.x());
    fnv1a(h, o.uv_left_px.y());
    fnv1a(h, o.uv_right_px.x());
    fnv1a(h, o.uv_right_px.y());
  }
}

Result run(const Sequence& s, const ums::RigCalibration& rig, int repeats) {
  ums::FrontendOptions opt;
  ums::Frontend fe(opt, rig);
  static ums::FrameFeatures out;
  std::vector<double> ms, cold;
  std::vector<double> stage[5], stage_cold[5];
  Result r;
  r.output_hash = 1469598103934665603ull;
  long n3 = 0, n2 = 0, frames = 0;
  std::uint64_t seq = 0;
  for (int rep = 0; rep < repeats; ++rep) {
    fe.reset();
    for (std::size_t i = 0; i < s.left.size(); ++i) {
      ums::StereoFrame f;
      f.seq = seq++;
      f.t_ns = static_cast<std::int64_t>(i) * 50'000'000;
      f.left = ums::ImageView{s.left[i].data(), s.width, s.height, s.width};
      f.right = ums::ImageView{s.right[i].data(), s.width, s.height, s.width};
      ums::AllocScope scope;
      const double c0 = thread_cpu_ms();
      const auto t0 = std::chrono::steady_clock::now();
      fe.process(f, nullptr, &out);
      const auto t1 = std::chrono::steady_clock::now();
      r.cpu_mean_ms += thread_cpu_ms() - c0;
      if (i > 0) r.allocs_after_first += scope.allocations();
      ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
      hash_features(&r.output_hash, out);
      double t[5];
      stage_times(out.stats, t);
      for (int k = 0; k < 5; ++k) stage[k].push_back(t[k]);
      n3 += out.n_3d;
      n2 += out.n_2d_left + out.n_2d_right;
      ++frames;
    }
  }
  for (std::size_t i = 0; i < s.left.size(); i += 5) {
    fe.reset();
    ums::StereoFrame f;
    f.seq = seq++;
    f.left = ums::ImageView{s.left[i].data(), s.width, s.height, s.width};
    f.right = ums::ImageView{s.right[i].data(), s.width, s.height, s.width};
    const auto t0 = std::chrono::steady_clock::now();
    fe.process(f, nullptr, &out);
    const auto t1 = std::chrono::steady_clock::now();
    cold.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    double t[5];
    stage_times(out.stats, t);
    for (int k = 0; k < 5; ++k) stage_cold[k].push_back(t[k]);
  }
  for (int k = 0; k < 5; ++k) {
    r.stage_median_ms[k] = median(stage[k]);
    for (double v : stage[k]) r.stage_mean_ms[k] += v;
    r.stage_mean_ms[k] /= static_cast<double>(stage[k].size());
    r.stage_cold_median_ms[k] = median(stage_cold[k]);
  }
  std::vector<double> sorted = ms;
  std::sort(sorted.begin(), sorted.end());
  r.median_ms = sorted[sorted.size() / 2];
  r.p99_ms = sorted[std::min(sorted.size() - 1, static_cast<std::size_t>(0.99 * static_cast<double>(sorted.size())))];
  r.max_ms = sorted.back();
  for (double v : ms) r.mean_ms += v;
  r.mean_ms /= static_cast<double>(ms.size());
  r.cpu_mean_ms /= static_cast<double>(ms.size());
  std::sort(cold.begin(), cold.end());
  r.cold_median_ms = cold[cold.size() / 2];
  r.cold_max_ms = cold.back();
  r.mean_3d = static_cast<double>(n3) / static_cast<double>(frames);
  r.mean_2d = static_cast<double>(n2) / static_cast<double>(frames);
  return r;
}

void print(const char* name, const Result& r) {
  std::printf("%s: steady median %.2f ms, p99 %.2f, max %.2f, mean %.2f (thread CPU %.2f) | cold (full detection) median %.2f, max %.2f | "
              "mean 3D %.1f, 2D %.1f | allocations after frame 1: %llu | output hash %016llx\n",
              name, r.median_ms, r.p99_ms, r.max_ms, r.mean_ms, r.cpu_mean_ms, r.cold_median_ms, r.cold_max_ms, r.mean_3d, r.mean_2d,
              r.allocs_after_first, static_cast<unsigned long long>(r.output_hash));
  double sum_mean = 0;
  for (double v : r.stage_mean_ms) sum_mean += v;
  std::printf("%s stages, steady median (mean, share of the summed means) | cold median, ms:", name);
  for (int k = 0; k < 5; ++k) {
    std::printf(" %s %.2f (%.2f, %.0f%%) | %.2f%s", kStageNames[k], r.stage_median_ms[k], r.stage_mean_ms[k],
                100.0 * r.stage_mean_ms[k] / sum_mean, r.stage_cold_median_ms[k], k < 4 ? ";" : "\n");
  }
}

void json(const char* key, const Result& r, bool last) {
  std::printf("\"%s\":{\"median_ms\":%.3f,\"p99_ms\":%.3f,\"max_ms\":%.3f,\"mean_ms\":%.3f,\"cpu_mean_ms\":%.3f,"
              "\"cold_median_ms\":%.3f,"
              "\"cold_max_ms\":%.3f,\"mean_3d\":%.1f,\"mean_2d\":%.1f,\"allocs_after_first\":%llu,\"output_hash\":\"%016llx\",",
              key, r.median_ms, r.p99_ms, r.max_ms, r.mean_ms, r.cpu_mean_ms, r.cold_median_ms, r.cold_max_ms, r.mean_3d, r.mean_2d,
              r.allocs_after_first, static_cast<unsigned long long>(r.output_hash));
  const char* groups[3] = {"stages_median_ms", "stages_mean_ms", "stages_cold_median_ms"};
  const double* values[3] = {r.stage_median_ms, r.stage_mean_ms, r.stage_cold_median_ms};
  for (int g = 0; g < 3; ++g) {
    std::printf("\"%s\":{", groups[g]);
    for (int k = 0; k < 5; ++k) std::printf("\"%s\":%.3f%s", kStageNames[k], values[g][k], k < 4 ? "," : "}");
    std::printf("%s", g < 2 ? "," : "");
  }
  std::printf("}%s", last ? "" : ",");
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string dir = argc > 1 ? argv[1] : std::string(UMS_SHARED_DIR) + "/data/euroc/V1_01_easy_micro";
    const int repeats = argc > 2 ? std::max(1, std::atoi(argv[2])) : 3;
    const Sequence native = load(dir);
    ums::RigCalibration rig;
    rig.cam[0] = ums::hal::read_euroc_camera_yaml(dir + "/mav0/cam0/sensor.yaml");
    rig.cam[1] = ums::hal::read_euroc_camera_yaml(dir + "/mav0/cam1/sensor.yaml");
    std::printf("frontend bench: %zu stereo pairs from %s, %d repeats, max_cnt %d\n", native.left.size(), dir.c_str(),
                repeats, ums::FrontendOptions{}.max_cnt);
    const Result a = run(native, rig, repeats);
    print("752x480", a);

    const int wide = 848;
    Sequence w848;
    w848.width = wide;
    w848.height = native.height;
    for (std::size_t i = 0; i < native.left.size(); ++i) {
      w848.left.push_back(resample_width(native.left[i], native.width, native.height, wide));
      w848.right.push_back(resample_width(native.right[i], native.width, native.height, wide));
    }
    ums::RigCalibration rig848 = rig;
    const double k = static_cast<double>(wide) / native.width;
    for (auto& c : rig848.cam) {
      c.width = wide;
      c.fx *= k;
      c.cx = (c.cx + 0.5) * k - 0.5;
    }
    const Result b = run(w848, rig848, repeats);
    print("848x480", b);
    std::printf("{\"bench\":\"frontend\",");
    json("752x480", a, false);
    json("848x480", b, true);
    std::printf("}\n");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "umsvins_bench_frontend: %s\n", e.what());
    return 1;
  }
  return 0;
}
