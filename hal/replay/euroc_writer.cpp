#include "hal/replay/euroc_writer.hpp"

#include <sys/stat.h>
#include <unistd.h>

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

}  // namespace

EurocWriter::~EurocWriter() { close_files(); }

void EurocWriter::close_files() {
  for (Csv& c : csv_) {
    if (c.f != nullptr) std::fclose(c.f);
    c.f = nullptr;
  }
}

void EurocWriter::create_csv(int which, const std::string& path, const char* header) {
  Csv& c = csv_[which];
  c.path = path;
  c.f = std::fopen(path.c_str(), "wb");
  if (c.f == nullptr) throw std::runtime_error(path + ": cannot create (" + std::strerror(errno) + ")");
  if (std::fprintf(c.f, "%s\n", header) < 0 || std::fflush(c.f) != 0) {
    throw std::runtime_error(path + ": cannot write (" + std::strerror(errno) + ")");
  }
  c.committed_bytes = std::ftell(c.f);
}

Status EurocWriter::commit() {
  for (Csv& c : csv_) {
    if (c.f == nullptr) continue;
    if (std::fflush(c.f) != 0 || std::ferror(c.f) != 0) {
      return roll_back(c.path + ": write failed (" + std::strerror(errno) + ")");
    }
  }
  for (Csv& c : csv_) {
    if (c.f != nullptr) c.committed_bytes = std::ftell(c.f);
  }
  frames_committed_ = frames_;
  imu_committed_ = imu_rows_;
  return Status::kOk;
}

Status EurocWriter::roll_back(const std::string& message) {
  close_files();  // what the buffers still hold may land partly: cut below
  for (Csv& c : csv_) {
    if (!c.path.empty()) (void)::truncate(c.path.c_str(), c.committed_bytes);
  }
  frames_ = frames_committed_;
  imu_rows_ = imu_committed_;
  return fail(Status::kIoError, message + "; the dataset keeps the " + std::to_string(frames_) +
                                    " frames and " + std::to_string(imu_rows_) + " IMU samples written before");
}

void EurocWriter::open(const std::string& dataset_dir, const RigCalibration& calibration,
                       bool with_groundtruth) {
  close_files();
  for (Csv& c : csv_) c = Csv();
  status_ = Status::kOk;
  error_.clear();
  any_frame_ = any_imu_ = any_gt_ = false;
  frames_ = imu_rows_ = frames_committed_ = imu_committed_ = 0;

  make_dir(dataset_dir);
  mav0_ = dataset_dir + "/mav0";
  make_dir(mav0_);
  for (int side = 0; side < 2; ++side) {
    const std::string cam = mav0_ + (side == 0 ? "/cam0" : "/cam1");
    make_dir(cam);
    make_dir(cam + "/data");
    write_euroc_camera_yaml(cam + "/sensor.yaml", calibration.cam[side],
                            side == 0 ? "cam0 (left)" : "cam1 (right)");
    create_csv(side == 0 ? kCam0 : kCam1, cam + "/data.csv", "#timestamp [ns],filename");
  }
  make_dir(mav0_ + "/imu0");
  write_euroc_imu_yaml(mav0_ + "/imu0/sensor.yaml", calibration.imu, "imu0");
  create_csv(kImu, mav0_ + "/imu0/data.csv",
                        "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
                        "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]");
  if (with_groundtruth) {
    make_dir(mav0_ + "/state_groundtruth_estimate0");
    create_csv(kGt, mav0_ + "/state_groundtruth_estimate0/data.csv", kEurocGroundtruthHeader);
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
  if (status_ == Status::kIoError) return status_;
  if (csv_[kCam0].f == nullptr) return fail(Status::kInvalidInput, "EurocWriter: not open");
  if (!frame.left.valid()) return fail(Status::kInvalidInput, "EurocWriter: invalid left image");
  if (any_frame_ && frame.t_ns <= last_frame_t_ns_) {
    return fail(Status::kInvalidInput, "EurocWriter: frame time " + std::to_string(frame.t_ns) +
                                           " not after " + std::to_string(last_frame_t_ns_));
  }
  char name[32];
  std::snprintf(name, sizeof(name), "%" PRId64 ".png", frame.t_ns);
  const ImageView* views[2] = {&frame.left, &frame.right};
  std::string paths[2];
  for (int side = 0; side < 2; ++side) {
    if (!views[side]->valid()) continue;
    std::string error;
    paths[side] = mav0_ + (side == 0 ? "/cam0/data/" : "/cam1/data/") + name;
    if (!write_png_gray8(paths[side], *views[side], &error)) {
      for (const std::string& p : paths) {
        if (!p.empty()) std::remove(p.c_str());  // no half frame, no truncated PNG
      }
      return roll_back(error);
    }
  }
  for (int side = 0; side < 2; ++side) {
    if (!paths[side].empty() && std::fprintf(csv_[side].f, "%" PRId64 ",%s\n", frame.t_ns, name) < 0) {
      return roll_back(csv_[side].path + ": write failed (" + std::strerror(errno) + ")");
    }
  }
  any_frame_ = true;
  last_frame_t_ns_ = frame.t_ns;
  ++frames_;
  return commit();
}

Status EurocWriter::write_imu(const ImuSample& s) {
  if (status_ == Status::kIoError) return status_;
  if (csv_[kImu].f == nullptr) return fail(Status::kInvalidInput, "EurocWriter: not open");
  if (any_imu_ && s.t_ns <= last_imu_t_ns_) {
    return fail(Status::kInvalidInput, "EurocWriter: IMU time " + std::to_string(s.t_ns) + " not after " +
                                           std::to_string(last_imu_t_ns_));
  }
  // %.17g: the reader gets the very same doubles back.
  if (std::fprintf(csv_[kImu].f, "%" PRId64 ",%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", s.t_ns, s.gyro_rad_s.x(),
                   s.gyro_rad_s.y(), s.gyro_rad_s.z(), s.accel_m_s2.x(), s.accel_m_s2.y(),
                   s.accel_m_s2.z()) < 0) {
    return roll_back(csv_[kImu].path + ": write failed (" + std::strerror(errno) + ")");
  }
  any_imu_ = true;
  last_imu_t_ns_ = s.t_ns;
  ++imu_rows_;
  return Status::kOk;
}

Status EurocWriter::write_groundtruth(const GroundTruthState& g) {
  if (status_ == Status::kIoError) return status_;
  if (csv_[kGt].f == nullptr) return fail(Status::kInvalidInput, "EurocWriter: opened without ground truth");
  if (any_gt_ && g.t_ns <= last_gt_t_ns_) {
    return fail(Status::kInvalidInput, "EurocWriter: ground-truth time " + std::to_string(g.t_ns) +
                                           " not after " + std::to_string(last_gt_t_ns_));
  }
  const Eigen::Quaterniond& q = g.q_w_b;
  if (std::fprintf(csv_[kGt].f,
                   "%" PRId64 ",%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,"
                   "%.17g,%.17g,%.17g,%.17g\n",
                   g.t_ns, g.p_w_b.x(), g.p_w_b.y(), g.p_w_b.z(), q.w(), q.x(), q.y(), q.z(), g.v_w_b.x(),
                   g.v_w_b.y(), g.v_w_b.z(), g.gyro_bias_rad_s.x(), g.gyro_bias_rad_s.y(),
                   g.gyro_bias_rad_s.z(), g.accel_bias_m_s2.x(), g.accel_bias_m_s2.y(),
                   g.accel_bias_m_s2.z()) < 0) {
    return roll_back(csv_[kGt].path + ": write failed (" + std::strerror(errno) + ")");
  }
  any_gt_ = true;
  last_gt_t_ns_ = g.t_ns;
  return Status::kOk;
}

void EurocWriter::on_imu(const ImuSample& sample) { write_imu(sample); }
void EurocWriter::on_stereo(const StereoFrame& frame) { write_stereo(frame); }

void EurocWriter::close() {
  if (commit() == Status::kOk) {
    for (Csv& c : csv_) {
      if (c.f != nullptr && std::fclose(c.f) != 0) fail(Status::kIoError, c.path + ": close failed");
      c.f = nullptr;
    }
  }
  if (status_ != Status::kOk) throw std::runtime_error(error_);
}

}  // namespace ums::hal
