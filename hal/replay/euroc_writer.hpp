#pragma once
// Writes a dataset in the EuRoC/ASL layout that EurocReader (and other EuRoC tools) read back:
//   <dir>/mav0/cam0|cam1/{sensor.yaml, data.csv, data/<t_ns>.png}, imu0/{sensor.yaml, data.csv},
//   optionally state_groundtruth_estimate0/data.csv.
// Used by the simulator and the D455 recorder. Also a MeasurementSink, so a source can push into
// it directly (reader -> writer copies a dataset).
//
// Per-frame cost: two PNG encodes through libpng, which allocates its encoder state per image
// (not a hot-path component: recording is I/O bound), and one flush of the CSVs.
//
// Nothing acknowledged is lost, and nothing half-written stays: every frame commits the rows so
// far (the CSVs are flushed and their sizes noted). When a write fails (a full disk, a file size
// limit), the frame's PNGs are removed and each CSV is cut back to its last committed size, so
// the folder is a valid dataset of everything committed before (frames_written(), imu_written()).

#include <cstdio>
#include <string>

#include "core/common/calibration.hpp"
#include "core/common/measurement_sink.hpp"
#include "core/common/status.hpp"
#include "hal/replay/euroc_groundtruth.hpp"

namespace ums::hal {

class EurocWriter : public MeasurementSink {
 public:
  EurocWriter() = default;
  ~EurocWriter() override;
  EurocWriter(const EurocWriter&) = delete;
  EurocWriter& operator=(const EurocWriter&) = delete;

  // Creates the folders (dataset_dir may exist; existing data.csv files are replaced), writes the
  // three sensor.yaml files and the CSV headers. Throws std::runtime_error naming the path.
  void open(const std::string& dataset_dir, const RigCalibration& calibration,
            bool with_groundtruth = false);

  // Writes both PNGs as <t_ns>.png and appends the rows. A frame with an invalid right view
  // writes cam0 only. kInvalidInput for a timestamp not after the previous one or an invalid
  // left view, kIoError when a file cannot be written (error() says which).
  Status write_stereo(const StereoFrame& frame);
  Status write_imu(const ImuSample& sample);             // kInvalidInput if not increasing
  Status write_groundtruth(const GroundTruthState& state);  // kInvalidInput if not opened with it

  // MeasurementSink: as write_*; the first failure is kept in status().
  void on_imu(const ImuSample& sample) override;
  void on_stereo(const StereoFrame& frame) override;

  // Flushes and closes the CSVs; throws std::runtime_error when a write failed at any point.
  void close();

  Status status() const { return status_; }
  const std::string& error() const { return error_; }
  // Rows in the dataset: committed (and, until a failure, the IMU rows since the last frame).
  std::uint64_t frames_written() const { return frames_; }
  std::uint64_t imu_written() const { return imu_rows_; }

 private:
  struct Csv {
    std::FILE* f = nullptr;
    std::string path;
    long committed_bytes = 0;  // size after the last successful flush
  };
  enum : int { kCam0 = 0, kCam1 = 1, kImu = 2, kGt = 3, kFiles = 4 };

  Status fail(Status s, const std::string& message);
  // A write failed: the CSVs are cut back to their committed sizes (files closed).
  Status roll_back(const std::string& message);
  Status commit();  // flushes every CSV; roll_back() when that fails
  void create_csv(int which, const std::string& path, const char* header);
  void close_files();

  std::string mav0_;
  Csv csv_[kFiles];
  std::uint64_t frames_committed_ = 0, imu_committed_ = 0;
  std::int64_t last_frame_t_ns_ = 0, last_imu_t_ns_ = 0, last_gt_t_ns_ = 0;
  bool any_frame_ = false, any_imu_ = false, any_gt_ = false;
  std::uint64_t frames_ = 0, imu_rows_ = 0;
  Status status_ = Status::kOk;
  std::string error_;
};

}  // namespace ums::hal
