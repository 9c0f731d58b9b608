#include "hal/d455/factory_calibration.hpp"

#include <fcntl.h>
#include <linux/usb/video.h>
#include <linux/uvcvideo.h>

#include <cmath>
#include <cstring>

namespace ums::d455 {

namespace {
template <typename T>
T load(const std::uint8_t* p) {
  T v{};
  std::memcpy(&v, p, sizeof(T));
  return v;
}
template <typename T>
void store(std::uint8_t* p, T v) {
  std::memcpy(p, &v, sizeof(T));
}

struct Resolution {
  int width, height;
};
// ds_rect_resolutions order of the coefficients table (notes §5.2); 10 and 11 are reserved.
constexpr Resolution kRectResolutions[16] = {{1920, 1080}, {1280, 720}, {640, 480}, {848, 480},
                                             {640, 360},   {424, 240},  {320, 240}, {480, 270},
                                             {1280, 800},  {960, 540},  {0, 0},     {0, 0},
                                             {640, 400},   {576, 576},  {720, 720}, {1152, 1152}};
constexpr std::size_t kTableHeader = 16;
constexpr std::size_t kCoefficientsTableBytes = 576;
}  // namespace

std::uint32_t crc32(const std::uint8_t* data, std::size_t size) {
  std::uint32_t crc = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < size; ++i) {
    crc ^= data[i];
    for (int b = 0; b < 8; ++b) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return crc ^ 0xFFFFFFFFu;
}

bool hwm_build_request(std::uint32_t opcode, const std::uint32_t params[4], const std::uint8_t* data,
                       std::size_t data_size, std::uint8_t out[kHwmBufferBytes]) {
  if (24 + data_size > kHwmBufferBytes) return false;
  std::memset(out, 0, kHwmBufferBytes);
  store<std::uint16_t>(out, static_cast<std::uint16_t>(20 + data_size));
  store<std::uint16_t>(out + 2, 0xCDABu);
  store<std::uint32_t>(out + 4, opcode);
  for (int i = 0; i < 4; ++i) store<std::uint32_t>(out + 8 + 4 * i, params[i]);
  if (data_size > 0) std::memcpy(out + 24, data, data_size);
  return true;
}

Status hwm_parse_reply(const std::uint8_t reply[kHwmBufferBytes], std::uint32_t opcode,
                       const std::uint8_t** payload, std::size_t* payload_size, std::string* error) {
  const auto echo = load<std::int32_t>(reply);
  if (echo < 0) {
    *error = "d455 hwm: device error " + std::to_string(echo) + " for opcode " + std::to_string(opcode);
    return Status::kIoError;
  }
  if (static_cast<std::uint32_t>(echo) != opcode) {
    *error = "d455 hwm: reply echoes opcode " + std::to_string(echo) + ", sent " + std::to_string(opcode);
    return Status::kIoError;
  }
  const auto length = load<std::uint32_t>(reply + 1020);
  if (length < 4 || length > 1020) {
    *error = "d455 hwm: reply length " + std::to_string(length) + " out of 4..1020";
    return Status::kIoError;
  }
  *payload = reply + 4;
  *payload_size = length - 4;
  return Status::kOk;
}

Status parse_stereo_coefficients(const std::uint8_t* table, std::size_t size, int width, int height,
                                 StereoFactoryCalibration* out, std::string* error) {
  if (size < kCoefficientsTableBytes) {
    *error = "d455 factory table: " + std::to_string(size) + " bytes, need " + std::to_string(kCoefficientsTableBytes);
    return Status::kInvalidInput;
  }
  const auto table_size = load<std::uint32_t>(table + 4);
  const auto crc = load<std::uint32_t>(table + 12);
  if (table_size + kTableHeader > size || table_size + kTableHeader < kCoefficientsTableBytes) {
    *error = "d455 factory table: header size " + std::to_string(table_size) + " does not fit " + std::to_string(size);
    return Status::kInvalidInput;
  }
  if (crc32(table + kTableHeader, table_size) != crc) {
    *error = "d455 factory table: CRC mismatch";
    return Status::kInvalidInput;
  }
  int index = -1;
  for (int i = 0; i < 16; ++i) {
    if (kRectResolutions[i].width == width && kRectResolutions[i].height == height) index = i;
  }
  if (index < 0) {
    *error = "d455 factory table: no entry for " + std::to_string(width) + "x" + std::to_string(height);
    return Status::kUnsupported;
  }
  const std::uint8_t* p = table + 256 + 16 * index;
  out->fx = static_cast<double>(load<float>(p));
  out->fy = static_cast<double>(load<float>(p + 4));
  out->cx = static_cast<double>(load<float>(p + 8));
  out->cy = static_cast<double>(load<float>(p + 12));
  out->baseline_m = std::fabs(static_cast<double>(load<float>(table + 160))) * 1e-3;
  const bool sane = out->fx > 0.3 * width && out->fx < 3.0 * width && out->fy > 0.3 * width &&
                    out->fy < 3.0 * width && out->cx > 0 && out->cx < width && out->cy > 0 &&
                    out->cy < height && out->baseline_m > 0.01 && out->baseline_m < 0.5;
  if (!sane) {
    *error = "d455 factory table: implausible values fx " + std::to_string(out->fx) + " cx " +
             std::to_string(out->cx) + " cy " + std::to_string(out->cy) + " baseline " +
             std::to_string(out->baseline_m) + " m";
    return Status::kInvalidInput;
  }
  return Status::kOk;
}

Status read_stereo_factory_calibration(Sys& sys, const std::string& video_path, int width, int height,
                                       StereoFactoryCalibration* out, std::string* error) {
  const int fd = sys.open(video_path.c_str(), O_RDWR | O_NONBLOCK);
  if (fd < 0) {
    *error = "d455 hwm: cannot open " + video_path;
    return Status::kIoError;
  }
  std::uint8_t buf[kHwmBufferBytes];
  const std::uint32_t params[4] = {kStereoCoefficientsTable, 0, 0, 0};
  hwm_build_request(kHwmGetIntCal, params, nullptr, 0, buf);
  Status status = Status::kIoError;
  uvc_xu_control_query q{};
  q.unit = 3;
  q.selector = 1;  // DS5_HWMONITOR
  q.size = static_cast<std::uint16_t>(kHwmBufferBytes);
  q.data = buf;
  q.query = UVC_SET_CUR;
  if (sys.ioctl(fd, UVCIOC_CTRL_QUERY, &q) < 0) {
    *error = "d455 hwm: SET_CUR on " + video_path + " failed";
  } else {
    std::memset(buf, 0, sizeof buf);
    q.query = UVC_GET_CUR;
    if (sys.ioctl(fd, UVCIOC_CTRL_QUERY, &q) < 0) {
      *error = "d455 hwm: GET_CUR on " + video_path + " failed";
    } else {
      const std::uint8_t* payload = nullptr;
      std::size_t n = 0;
      status = hwm_parse_reply(buf, kHwmGetIntCal, &payload, &n, error);
      if (status == Status::kOk) status = parse_stereo_coefficients(payload, n, width, height, out, error);
    }
  }
  sys.close(fd);
  return status;
}

void apply_stereo_factory_calibration(const StereoFactoryCalibration& factory, RigCalibration* rig) {
  for (int side = 0; side < 2; ++side) {
    CameraCalibration& c = rig->cam[side];
    c.model = CameraModel::kPinholeRadTan;
    c.fx = factory.fx;
    c.fy = factory.fy;
    c.cx = factory.cx;
    c.cy = factory.cy;
    c.distortion = {0.0, 0.0, 0.0, 0.0};
  }
  rig->cam[1].T_b_c = rig->cam[0].T_b_c;
  rig->cam[1].T_b_c.translation() += rig->cam[0].T_b_c.linear() * Eigen::Vector3d(factory.baseline_m, 0.0, 0.0);
}

}  // namespace ums::d455
