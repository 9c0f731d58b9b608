#include "hal/replay/euroc_writer.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cinttypes>
#include <cstring>
#include <stdexcept>

#include "hal/replay/euroc_sensor_yaml.hpp"
#include "hal/replay/png_io.hpp"

namespace ums::hal {

namespace {

void make_dir(const std::string& path) {
  if (::mkdir(path.c_str(), 0775) != 0 && errno != EEXIST) {
    throw std::runtime_error(path + ": cannot create folder (" + std::strerror(errno) + ")");
  }
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
    throw std::runtime_error(path + ": exists and is not a folder");
  }
}

std::FILE* create_csv(const std::string& path, const char* header) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) throw std::runtime_error(path + ": cannot create (" + std::strerror(errno) + ")");
  std::fprintf(f, "%s\n", header);
  return f;
}

}  // namespace

EurocWriter::~EurocWriter() { close_files(); }

void EurocWriter::close_files() {
  for (std::FILE** f : {&cam_csv_[0], &cam_csv_[1], &imu_csv_, &gt_csv_}) {
    if (*f != nullptr) std::fclose(*f);
    *f = nullptr;
  }
}

void EurocWriter::open(const std::string& dataset_dir, const RigCalibration& calibration,
                       bool with_groundtruth) {
  close_files();
  status_ = Status::kOk;
  error_.clear();
  any_frame_ = any_imu_ = any_gt_ = false;
  frames_ = imu_rows_ = 0;

  make_dir(dataset_dir);
  mav0_ = dataset_dir + "/mav0";
  make_dir(mav0_);
  for (int side = 0; side < 2; ++side) {
    const std::string cam = mav0_ + (side == 0 ? "/cam0" : "/cam1");
    make_dir(cam);
    make_dir(cam + "/data");
    write_euroc_camera_yaml(cam + "/sensor.yaml", calibration.cam[side],
                            side == 0 ? "cam0 (left)" : "cam1 (right)");
    cam_csv_[side] = create_csv(cam + "/data.csv", "#timestamp [ns],filename");
  }
  make_dir(mav0_ + "/imu0");
  write_euroc_imu_yaml(mav0_ + "/imu0/sensor.yaml", calibration.imu, "imu0");
  imu_csv_ = create_csv(mav0_ + "/imu0/data.csv",
                        "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
                        "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]");
  if (with_groundtruth) {
    make_dir(mav0_ + "/state_groundtruth_estimate0");
    gt_csv_ = create_csv(mav0_ + "/state_groundtruth_estimate0/data.csv", kEurocGroundtruthHeader);
  }
}

Status EurocWriter::fail(Status s, const std::string& message) {
  if (status_ == Status::kOk) {
    status_ = s;
    error_ = message;
  }
  return s;
}

Status EurocWriter::write_stereo(const StereoFrame& frame) {
  if (cam_csv_[0] == nullptr) return fail(Status::kInvalidInput, "EurocWriter: not open");
  if (!frame.left.valid()) return fail(Status::kInvalidInput, "EurocWriter: invalid left image");
  if (any_frame_ && frame.t_ns <= last_frame_t_ns_) {
    return fail(Status::kInvalidInput, "EurocWriter: frame time " + std::to_string(frame.t_ns) +
                                           " not after " + std::to_string(last_frame_t_ns_));
  }
  char name[32];
  std::snprintf(name, sizeof(name), "%" PRId64 ".png", frame.t_ns);
  const ImageView* views[2] = {&frame.left, &frame.right};
  for (int side = 0; side < 2; ++side) {
    if (!views[side]->valid()) continue;
    std::string error;
    const std::string path = mav0_ + (side == 0 ? "/cam0/data/" : "/cam1/data/") + name;
    if (!write_png_gray8(path, *views[side], &error)) return fail(Status::kIoError, error);
    if (std::fprintf(cam_csv_[side], "%" PRId64 ",%s\n", frame.t_ns, name) < 0) {
      return fail(Status::kIoError, mav0_ + (side == 0 ? "/cam0" : "/cam1") + "/data.csv: write failed");
    }
  }
  any_frame_ = true;
  last_frame_t_ns_ = frame.t_ns;
  ++frames_;
  return Status::kOk;
}

Status EurocWriter::write_imu(const ImuSample& s) {
  if (imu_csv_ == nullptr) return fail(Status::kInvalidInput, "EurocWriter: not open");
  if (any_imu_ && s.t_ns <= last_imu_t_ns_) {
    return fail(Status::kInvalidInput, "EurocWriter: IMU time " + std::to_string(s.t_ns) + " not after " +
                                           std::to_string(last_imu_t_ns_));
  }
  // %.17g: the reader gets the very same doubles back.
  if (std::fprintf(imu_csv_, "%" PRId64 ",%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", s.t_ns, s.gyro_rad_s.x(),
                   s.gyro_rad_s.y(), s.gyro_rad_s.z(), s.accel_m_s2.x(), s.accel_m_s2.y(),
                   s.accel_m_s2.z()) < 0) {
    return fail(Status::kIoError, mav0_ + "/imu0/data.csv: write failed");
  }
  any_imu_ = true;
  last_imu_t_ns_ = s.t_ns;
  ++imu_rows_;
  return Status::kOk;
}

Status EurocWriter::write_groundtruth(const GroundTruthState& g) {
  if (gt_csv_ == nullptr) return fail(Status::kInvalidInput, "EurocWriter: opened without ground truth");
  if (any_gt_ && g.t_ns <= last_gt_t_ns_) {
    return fail(Status::kInvalidInput, "EurocWriter: ground-truth time " + std::to_string(g.t_ns) +
                                           " not after " + std::to_string(last_gt_t_ns_));
  }
  const Eigen::Quaterniond& q = g.q_w_b;
  if (std::fprintf(gt_csv_,
                   "%" PRId64 ",%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,"
                   "%.17g,%.17g,%.17g,%.17g\n",
                   g.t_ns, g.p_w_b.x(), g.p_w_b.y(), g.p_w_b.z(), q.w(), q.x(), q.y(), q.z(), g.v_w_b.x(),
                   g.v_w_b.y(), g.v_w_b.z(), g.gyro_bias_rad_s.x(), g.gyro_bias_rad_s.y(),
                   g.gyro_bias_rad_s.z(), g.accel_bias_m_s2.x(), g.accel_bias_m_s2.y(),
                   g.accel_bias_m_s2.z()) < 0) {
    return fail(Status::kIoError, mav0_ + "/state_groundtruth_estimate0/data.csv: write failed");
  }
  any_gt_ = true;
  last_gt_t_ns_ = g.t_ns;
  return Status::kOk;
}

void EurocWriter::on_imu(const ImuSample& sample) { write_imu(sample); }
void EurocWriter::on_stereo(const StereoFrame& frame) { write_stereo(frame); }

void EurocWriter::close() {
  bool ok = true;
  for (std::FILE** f : {&cam_csv_[0], &cam_csv_[1], &imu_csv_, &gt_csv_}) {
    if (*f != nullptr) {
      ok = (std::fflush(*f) == 0) && (std::ferror(*f) == 0) && ok;
      ok = (std::fclose(*f) == 0) && ok;
    }
    *f = nullptr;
  }
  if (!ok) fail(Status::kIoError, mav0_ + ": flushing the CSV files failed");
  if (status_ != Status::kOk) throw std::runtime_error(error_);
}

}  // namespace ums::hal
