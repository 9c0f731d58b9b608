#include "hal/replay/euroc_reader.hpp"

#include <sys/stat.h>

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "core/common/capacity.hpp"
#include "hal/replay/csv_reader.hpp"
#include "hal/replay/euroc_sensor_yaml.hpp"
#include "hal/replay/png_io.hpp"

namespace ums::hal {

namespace {

constexpr std::int64_t kNoLimitNs = std::numeric_limits<std::int64_t>::max();
constexpr std::size_t kMaxFileNameBytes = 256;  // bytes of a data.csv filename column

bool is_dir(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

bool is_file(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

struct CameraRow {
  std::int64_t t_ns = 0;
  long line = 0;
  char file[kMaxFileNameBytes] = {};
};

// A data.csv read row by row with the row waiting to be consumed and the ordering check.
struct CameraStream {
  CsvReader csv;
  CameraRow row;
  bool has_row = false;
  std::int64_t previous_t_ns = 0;
  long previous_line = 0;  // 0: no row yet

  void restart(const std::string& path) {
    csv.open(path);
    has_row = false;
    previous_line = 0;
  }

  // One row of "timestamp [ns], filename", in increasing time.
  CsvReader::Result read() {
    const CsvReader::Result r = csv.next();
    if (r != CsvReader::Result::kRow) return r;
    if (csv.field_count() != 2) {
      return csv.fail("expected 2 columns (timestamp [ns], filename), found %zu", csv.field_count());
    }
    std::int64_t t = 0;
    if (!csv.field_int64(0, &t)) return csv.fail("timestamp '%s' is not an integer (ns)", csv.field(0));
    const std::size_t name_length = std::strlen(csv.field(1));
    if (name_length == 0) return csv.fail("empty filename");
    if (name_length >= kMaxFileNameBytes) {
      return csv.fail("filename longer than %zu bytes", kMaxFileNameBytes - 1);
    }
    if (previous_line > 0 && t <= previous_t_ns) {
      if (t == previous_t_ns) {
        return csv.fail("duplicate timestamp %" PRId64 " (also on line %ld)", t, previous_line);
      }
      return csv.fail("timestamp %" PRId64 " is earlier than %" PRId64 " on line %ld (timestamps must increase)",
                      t, previous_t_ns, previous_line);
    }
    previous_t_ns = t;
    previous_line = csv.line();
    row.t_ns = t;
    row.line = csv.line();
    std::memcpy(row.file, csv.field(1), name_length + 1);
    return r;
  }
};

struct ImuStream {
  CsvReader csv;
  ImuSample row;
  bool has_row = false;
  std::int64_t previous_t_ns = 0;
  long previous_line = 0;

  void restart(const std::string& path) {
    csv.open(path);
    has_row = false;
    previous_line = 0;
  }

  // One row of "timestamp [ns], w_x, w_y, w_z [rad/s], a_x, a_y, a_z [m/s^2]".
  CsvReader::Result read() {
    const CsvReader::Result r = csv.next();
    if (r != CsvReader::Result::kRow) return r;
    if (csv.field_count() != 7) {
      return csv.fail("expected 7 columns (timestamp [ns], w_x, w_y, w_z [rad/s], a_x, a_y, a_z [m/s^2]), found %zu",
                      csv.field_count());
    }
    std::int64_t t = 0;
    if (!csv.field_int64(0, &t)) return csv.fail("timestamp '%s' is not an integer (ns)", csv.field(0));
    double v[6];
    for (std::size_t i = 0; i < 6; ++i) {
      if (!csv.field_double(i + 1, &v[i])) {
        return csv.fail("column %zu ('%s') is not a finite number", i + 1, csv.field(i + 1));
      }
    }
    if (previous_line > 0 && t <= previous_t_ns) {
      if (t == previous_t_ns) {
        return csv.fail("duplicate timestamp %" PRId64 " (also on line %ld)", t, previous_line);
      }
      return csv.fail("timestamp %" PRId64 " is earlier than %" PRId64 " on line %ld (timestamps must increase)",
                      t, previous_t_ns, previous_line);
    }
    previous_t_ns = t;
    previous_line = csv.line();
    row.t_ns = t;
    row.gyro_rad_s = Eigen::Vector3d(v[0], v[1], v[2]);
    row.accel_m_s2 = Eigen::Vector3d(v[3], v[4], v[5]);
    return r;
  }
};

}  // namespace

void EurocReaderOptions::validate() const {
  // Bounded so that start + duration in ns cannot overflow int64.
  if (!std::isfinite(start_s) || start_s < 0.0 || start_s > 1e7) {
    throw std::invalid_argument("EurocReaderOptions.start_s must be in 0..1e7 s, got " + std::to_string(start_s));
  }
  if (!std::isfinite(duration_s) || duration_s < 0.0 || duration_s > 1e7) {
    throw std::invalid_argument("EurocReaderOptions.duration_s must be in 0..1e7 s (0 = to the end), got " +
                                std::to_string(duration_s));
  }
  if (!std::isfinite(imu_lead_s) || imu_lead_s < 0.0 || imu_lead_s > 10.0) {
    throw std::invalid_argument("EurocReaderOptions.imu_lead_s must be in 0..10 s, got " + std::to_string(imu_lead_s));
  }
  if (pair_tolerance_ns < 0) {
    throw std::invalid_argument("EurocReaderOptions.pair_tolerance_ns must be >= 0 ns, got " +
                                std::to_string(pair_tolerance_ns));
  }
}

struct EurocReader::Impl {
  RigCalibration calibration;
  EurocReaderOptions options;
  EurocFileSummary summary;
  EurocReaderCounters counters;
  std::string mav0;
  std::string csv_path[2];
  std::string yaml_path[2];
  std::string imu_csv_path;
  std::string groundtruth_path;
  bool has_groundtruth = false;
  std::size_t total_pairs = 0;
  std::int64_t window_start_ns = 0;
  std::int64_t window_end_ns = 0;
  std::int64_t imu_start_ns = 0;

  CameraStream cam[2];
  ImuStream imu;
  bool pair_ready = false;
  bool frames_done = false;
  CameraRow pair[2];
  std::uint64_t seq = 0;

  PngGrayReader png;
  std::unique_ptr<std::uint8_t[]> image[2];
  std::size_t image_capacity[2] = {0, 0};
  char data_dir[2][capacity::kMaxPathLength] = {};  // "<mav0>/camN/data/"
  char path[capacity::kMaxPathLength] = {};

  bool opened = false;  // open() completed
  Status status = Status::kOk;
  char error[capacity::kMaxPathLength + 512] = {};
  char image_error[capacity::kMaxPathLength + 512] = {};

  void fail_stream(const char* message) {
    status = Status::kIoError;
    std::snprintf(error, sizeof(error), "%s", message);
  }

  // Next camera row inside the window; false at the window's end, the file's end or an error.
  bool advance(CameraStream& s) {
    for (;;) {
      const CsvReader::Result r = s.read();
      if (r == CsvReader::Result::kError) fail_stream(s.csv.error());
      if (r != CsvReader::Result::kRow || s.row.t_ns > window_end_ns) return s.has_row = false;
      if (s.row.t_ns >= window_start_ns) return s.has_row = true;
    }
  }

  bool advance_imu() {
    for (;;) {
      const CsvReader::Result r = imu.read();
      if (r == CsvReader::Result::kError) fail_stream(imu.csv.error());
      if (r != CsvReader::Result::kRow || imu.row.t_ns > window_end_ns) return imu.has_row = false;
      if (imu.row.t_ns >= imu_start_ns) return imu.has_row = true;
    }
  }

  // Merges the two camera streams up to the next pair; counts rows left without a partner.
  bool next_pair() {
    while (cam[0].has_row && cam[1].has_row) {
      const std::int64_t dt = cam[0].row.t_ns - cam[1].row.t_ns;
      if (dt <= options.pair_tolerance_ns && -dt <= options.pair_tolerance_ns) {
        pair[0] = cam[0].row;
        pair[1] = cam[1].row;
        advance(cam[0]);
        advance(cam[1]);
        return status == Status::kOk;
      }
      if (dt < 0) {
        ++counters.unpaired_left;
        advance(cam[0]);
      } else {
        ++counters.unpaired_right;
        advance(cam[1]);
      }
    }
    while (cam[0].has_row) {
      ++counters.unpaired_left;
      advance(cam[0]);
    }
    while (cam[1].has_row) {
      ++counters.unpaired_right;
      advance(cam[1]);
    }
    return false;
  }

  const char* image_path(int side) {
    std::snprintf(path, sizeof(path), "%s%s", data_dir[side], pair[side].file);
    return path;
  }

  bool decode_pair(StereoFrame* frame) {
    int width[2] = {0, 0}, height[2] = {0, 0};
    bool ok = true;
    for (int side = 0; side < 2; ++side) {
      char reason[256];
      const CameraCalibration& cal = calibration.cam[side];
      const char* file = image_path(side);
      bool good = png.read(file, image[side].get(), image_capacity[side], &width[side], &height[side],
                           reason, sizeof(reason));
      if (good && (width[side] != cal.width || height[side] != cal.height)) {
        std::snprintf(reason, sizeof(reason), "image is %dx%d, sensor.yaml resolution is [%d, %d]",
                      width[side], height[side], cal.width, cal.height);
        good = false;
      }
      if (!good) {
        ++counters.unreadable_images;
        std::snprintf(image_error, sizeof(image_error), "%s: %s (%s line %ld)", file, reason,
                      csv_path[side].c_str(), pair[side].line);
        ok = false;
      }
    }
    const std::uint64_t index = seq++;
    if (!ok) return false;
    frame->t_ns = pair[0].t_ns;
    frame->seq = index;
    frame->left = ImageView{image[0].get(), width[0], height[0], width[0]};
    frame->right = ImageView{image[1].get(), width[1], height[1], width[1]};
    return true;
  }

  void rewind_streams() {
    for (int side = 0; side < 2; ++side) {
      cam[side].restart(csv_path[side]);
      advance(cam[side]);
    }
    imu.restart(imu_csv_path);
    advance_imu();
    pair_ready = false;
    frames_done = false;
    seq = 0;
    counters = EurocReaderCounters{};
    status = Status::kOk;
    error[0] = '\0';
    image_error[0] = '\0';
  }
};

EurocReader::EurocReader() : impl_(new Impl) {}
EurocReader::~EurocReader() = default;

void EurocReader::open(const std::string& dataset_dir, const EurocReaderOptions& options) {
  options.validate();
  Impl& m = *impl_;
  m.opened = false;
  m.options = options;

  if (!is_dir(dataset_dir)) throw std::runtime_error(dataset_dir + ": no such folder");
  std::string mav0 = dataset_dir + "/mav0";
  if (!is_dir(mav0)) {
    if (is_dir(dataset_dir + "/cam0") && is_dir(dataset_dir + "/imu0")) {
      mav0 = dataset_dir;
    } else {
      throw std::runtime_error(dataset_dir +
                               ": no mav0/ folder (expected the EuRoC layout mav0/cam0, mav0/cam1, mav0/imu0)");
    }
  }
  m.mav0 = mav0;
  for (int side = 0; side < 2; ++side) {
    const std::string cam = mav0 + (side == 0 ? "/cam0" : "/cam1");
    if (!is_dir(cam)) throw std::runtime_error(cam + ": no such folder");
    m.csv_path[side] = cam + "/data.csv";
    m.yaml_path[side] = cam + "/sensor.yaml";
    const std::string data = cam + "/data/";
    if (data.size() + kMaxFileNameBytes >= capacity::kMaxPathLength) {
      throw std::runtime_error(data + ": path longer than capacity::kMaxPathLength");
    }
    std::snprintf(m.data_dir[side], sizeof(m.data_dir[side]), "%s", data.c_str());
  }
  if (!is_dir(mav0 + "/imu0")) throw std::runtime_error(mav0 + "/imu0: no such folder");
  m.imu_csv_path = mav0 + "/imu0/data.csv";
  m.groundtruth_path = mav0 + "/state_groundtruth_estimate0/data.csv";
  m.has_groundtruth = is_file(m.groundtruth_path);

  m.calibration = RigCalibration{};
  m.calibration.cam[0] = read_euroc_camera_yaml(m.yaml_path[0]);
  m.calibration.cam[1] = read_euroc_camera_yaml(m.yaml_path[1]);
  m.calibration.imu = read_euroc_imu_yaml(mav0 + "/imu0/sensor.yaml");

  // Validation pass over whole files: every row parsed and ordered, before anything streams.
  m.window_start_ns = std::numeric_limits<std::int64_t>::min();
  m.imu_start_ns = m.window_start_ns;
  m.window_end_ns = kNoLimitNs;
  EurocFileSummary& sum = m.summary;
  sum = EurocFileSummary{};
  for (int side = 0; side < 2; ++side) {
    CameraStream& s = m.cam[side];
    s.restart(m.csv_path[side]);
    std::uint64_t rows = 0;
    CsvReader::Result r;
    while ((r = s.read()) == CsvReader::Result::kRow) {
      if (rows++ == 0) (side == 0 ? sum.cam0_first_t_ns : sum.cam1_first_t_ns) = s.row.t_ns;
      (side == 0 ? sum.cam0_last_t_ns : sum.cam1_last_t_ns) = s.row.t_ns;
    }
    if (r == CsvReader::Result::kError) throw std::runtime_error(s.csv.error());
    if (rows == 0) throw std::runtime_error(m.csv_path[side] + ": no data rows");
    (side == 0 ? sum.cam0_rows : sum.cam1_rows) = rows;
  }
  {
    m.imu.restart(m.imu_csv_path);
    CsvReader::Result r;
    while ((r = m.imu.read()) == CsvReader::Result::kRow) {
      if (sum.imu_rows++ == 0) sum.imu_first_t_ns = m.imu.row.t_ns;
      sum.imu_last_t_ns = m.imu.row.t_ns;
    }
    if (r == CsvReader::Result::kError) throw std::runtime_error(m.imu.csv.error());
    if (sum.imu_rows == 0) throw std::runtime_error(m.imu_csv_path + ": no data rows");
  }

  // The replay window, from the first left frame.
  const double length_s = 1e-9 * static_cast<double>(sum.cam0_last_t_ns - sum.cam0_first_t_ns);
  if (options.start_s > length_s) {
    throw std::invalid_argument("EurocReaderOptions.start_s = " + std::to_string(options.start_s) +
                                " s is after the last frame (" + m.csv_path[0] + " spans " +
                                std::to_string(length_s) + " s)");
  }
  m.window_start_ns = sum.cam0_first_t_ns + static_cast<std::int64_t>(std::llround(options.start_s * 1e9));
  m.imu_start_ns = m.window_start_ns - static_cast<std::int64_t>(std::llround(options.imu_lead_s * 1e9));
  m.window_end_ns = options.duration_s > 0.0
                        ? m.window_start_ns + static_cast<std::int64_t>(std::llround(options.duration_s * 1e9))
                        : kNoLimitNs;

  // Image buffers, once, from sensor.yaml (bounded by the capacities the yaml reader checks).
  for (int side = 0; side < 2; ++side) {
    const CameraCalibration& cal = m.calibration.cam[side];
    const std::size_t bytes = static_cast<std::size_t>(cal.width) * static_cast<std::size_t>(cal.height);
    if (bytes != m.image_capacity[side]) {
      m.image[side].reset(new std::uint8_t[bytes]);
      m.image_capacity[side] = bytes;
    }
  }

  // Pairing pass: counts the pairs of the window and checks each PNG header against sensor.yaml
  // (a wrong resolution in sensor.yaml fails here, not frame by frame).
  m.rewind_streams();
  m.total_pairs = 0;
  while (m.next_pair()) {
    ++m.total_pairs;
    for (int side = 0; side < 2; ++side) {
      int w = 0, h = 0;
      const CameraCalibration& cal = m.calibration.cam[side];
      if (read_png_size(m.image_path(side), &w, &h) && (w != cal.width || h != cal.height)) {
        throw std::runtime_error(m.csv_path[side] + ":" + std::to_string(m.pair[side].line) + ": image " +
                                 m.pair[side].file + " is " + std::to_string(w) + "x" + std::to_string(h) +
                                 " but " + m.yaml_path[side] + " has resolution [" +
                                 std::to_string(cal.width) + ", " + std::to_string(cal.height) + "]");
      }
    }
  }
  if (m.status != Status::kOk) throw std::runtime_error(m.error);
  m.rewind_streams();
  if (m.status != Status::kOk) throw std::runtime_error(m.error);
  m.opened = true;
}

EurocReader::Event EurocReader::next(ImuSample* imu, StereoFrame* frame) {
  Impl& m = *impl_;
  if (!m.opened) return Event::kEnd;
  for (;;) {
    if (m.status != Status::kOk) return Event::kEnd;
    if (!m.pair_ready && !m.frames_done) {
      m.pair_ready = m.next_pair();
      m.frames_done = !m.pair_ready;
      if (m.status != Status::kOk) return Event::kEnd;
    }
    if (m.imu.has_row) {
      const std::int64_t limit = m.pair_ready ? m.pair[0].t_ns
                                 : m.options.imu_after_last_frame ? m.window_end_ns
                                                                   : std::numeric_limits<std::int64_t>::min();
      if (m.imu.row.t_ns <= limit) {
        *imu = m.imu.row;
        ++m.counters.imu_samples;
        m.advance_imu();
        return Event::kImu;
      }
    }
    if (!m.pair_ready) return Event::kEnd;
    m.pair_ready = false;
    if (m.decode_pair(frame)) {
      ++m.counters.stereo_pairs;
      return Event::kStereo;
    }
  }
}

Status EurocReader::push_all(MeasurementSink& sink) {
  ImuSample imu;
  StereoFrame frame;
  for (;;) {
    switch (next(&imu, &frame)) {
      case Event::kImu: sink.on_imu(imu); break;
      case Event::kStereo: sink.on_stereo(frame); break;
      case Event::kEnd: return impl_->status;
    }
  }
}

const RigCalibration& EurocReader::calibration() const { return impl_->calibration; }
const EurocReaderCounters& EurocReader::counters() const { return impl_->counters; }
const EurocFileSummary& EurocReader::summary() const { return impl_->summary; }
Status EurocReader::status() const { return impl_->status; }
const char* EurocReader::error() const { return impl_->error; }
const char* EurocReader::last_image_error() const { return impl_->image_error; }
std::size_t EurocReader::total_pairs_estimate() const { return impl_->total_pairs; }
std::int64_t EurocReader::first_frame_t_ns() const { return impl_->summary.cam0_first_t_ns; }
std::int64_t EurocReader::last_frame_t_ns() const { return impl_->summary.cam0_last_t_ns; }
std::int64_t EurocReader::window_start_t_ns() const { return impl_->window_start_ns; }
std::int64_t EurocReader::window_end_t_ns() const { return impl_->window_end_ns; }
bool EurocReader::has_groundtruth() const { return impl_->has_groundtruth; }
std::string EurocReader::groundtruth_path() const { return impl_->groundtruth_path; }
std::string EurocReader::mav0_path() const { return impl_->mav0; }
const PngGrayReader& EurocReader::png_reader() const { return impl_->png; }

}  // namespace ums::hal
