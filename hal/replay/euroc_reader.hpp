#pragma once
// Replays a dataset in the EuRoC/ASL layout (the folder holding mav0/) as one time-ordered stream
// of IMU samples and stereo frames, in bounded memory:
//  - open() reads the sensor.yaml files, validates every CSV row by a streaming pass (so bad
//    input fails before processing starts, with file and line), pairs cam0/cam1 rows by
//    timestamp and checks the PNG headers of the pairs against sensor.yaml's resolution;
//  - next() then reads the CSVs row by row and decodes each pair into two image buffers that
//    open() allocated once: nothing of the sequence is held in RAM and, with the heap-free PNG
//    decoder, next() allocates nothing.
//
// Stream order: before a frame at t, every IMU sample with t_imu <= t. Frames are pairs of cam0
// and cam1 rows whose timestamps differ by at most pair_tolerance_ns (the pair takes cam0's
// time); a row without partner is counted and skipped, as is a pair with a PNG that cannot be
// decoded. Only rows inside the replay window [first cam0 time + start_s, + duration_s] count;
// IMU rows from imu_lead_s before the window's start are streamed too.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "core/common/calibration.hpp"
#include "core/common/imu_sample.hpp"
#include "core/common/measurement_sink.hpp"
#include "core/common/status.hpp"
#include "core/common/stereo_frame.hpp"

namespace ums::hal {

class PngGrayReader;

struct EurocReaderOptions {
  double start_s = 0.0;                // s after the first cam0 timestamp where replay starts
  double duration_s = 0.0;             // s of replay after start; 0 = to the end
  std::int64_t pair_tolerance_ns = 0;  // ns; cam0/cam1 rows this close form a pair (EuRoC: exact)
  bool imu_after_last_frame = false;   // also stream IMU rows after the last frame (to window end)
  double imu_lead_s = 0.1;             // s of IMU streamed before the window's start, so the first
                                       // frame has IMU on both sides (attitude, interpolation)

  void validate() const;  // throws std::invalid_argument naming the field and value
};

struct EurocReaderCounters {
  std::uint64_t imu_samples = 0;        // IMU samples streamed
  std::uint64_t stereo_pairs = 0;       // stereo frames streamed
  std::uint64_t unpaired_left = 0;      // cam0 rows in the window without a cam1 partner
  std::uint64_t unpaired_right = 0;     // cam1 rows in the window without a cam0 partner
  std::uint64_t unreadable_images = 0;  // PNGs of paired rows that could not be decoded (pair skipped)
};

// What the validation pass of open() found (whole files, not only the window).
struct EurocFileSummary {
  std::uint64_t cam0_rows = 0;
  std::uint64_t cam1_rows = 0;
  std::uint64_t imu_rows = 0;
  std::int64_t cam0_first_t_ns = 0, cam0_last_t_ns = 0;
  std::int64_t cam1_first_t_ns = 0, cam1_last_t_ns = 0;
  std::int64_t imu_first_t_ns = 0, imu_last_t_ns = 0;
};

class EurocReader {
 public:
  enum class Event { kImu, kStereo, kEnd };

  EurocReader();
  ~EurocReader();
  EurocReader(const EurocReader&) = delete;
  EurocReader& operator=(const EurocReader&) = delete;

  // Start-up. Throws std::runtime_error "<file>:<line>: <problem>" (or "<file>: key '<k>': ...")
  // on a missing file or folder, a malformed row, non-increasing timestamps, an image whose size
  // differs from sensor.yaml; std::invalid_argument on invalid options. Calling it again restarts.
  // dataset_dir may also be the mav0/ folder itself.
  void open(const std::string& dataset_dir, const EurocReaderOptions& options = {});

  const RigCalibration& calibration() const;

  // Next measurement in time order; fills *imu or *frame. A frame's image views stay valid until
  // the next call. Returns kEnd at the end, and also after a read error while streaming (files
  // changed since open): then status() is kIoError and error() says where. kEnd before a
  // successful open().
  Event next(ImuSample* imu, StereoFrame* frame);

  // Streams everything (from the current position) into sink; kOk at the end, or status().
  Status push_all(MeasurementSink& sink);

  const EurocReaderCounters& counters() const;
  const EurocFileSummary& summary() const;
  Status status() const;
  const char* error() const;             // streaming error, "" if none
  const char* last_image_error() const;  // why the last skipped PNG failed, "" if none

  // For progress displays: pairs in the window as counted by open() (exact unless PNGs turn out
  // unreadable), the first/last cam0 timestamps of the files, and the replay window.
  std::size_t total_pairs_estimate() const;
  std::int64_t first_frame_t_ns() const;
  std::int64_t last_frame_t_ns() const;
  std::int64_t window_start_t_ns() const;  // frames; IMU starts imu_lead_s earlier
  std::int64_t window_end_t_ns() const;  // INT64_MAX when the window runs to the end

  bool has_groundtruth() const;
  std::string groundtruth_path() const;  // <mav0>/state_groundtruth_estimate0/data.csv
  std::string mav0_path() const;

  const PngGrayReader& png_reader() const;  // decoder arena statistics

  struct Impl;  // state; public only for the helpers in the .cpp

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace ums::hal
