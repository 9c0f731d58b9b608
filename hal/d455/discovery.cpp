#include "hal/d455/discovery.hpp"

#include <fcntl.h>
#include <linux/videodev2.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace ums::d455 {

bool parse_usb_modalias(const std::string& modalias, unsigned* vid, unsigned* pid) {
  // Format: usb:vVVVVpPPPPd... (upper-case hex), kernel drivers/usb/core/sysfs.c.
  if (modalias.size() < 14 || modalias.compare(0, 5, "usb:v") != 0 || modalias[9] != 'p') return false;
  char* end = nullptr;
  const std::string v = modalias.substr(5, 4);
  const std::string p = modalias.substr(10, 4);
  *vid = static_cast<unsigned>(std::strtoul(v.c_str(), &end, 16));
  if (*end != '\0') return false;
  *pid = static_cast<unsigned>(std::strtoul(p.c_str(), &end, 16));
  return *end == '\0';
}

namespace {

struct VideoNode {
  int number = -1;
  std::string name;       // videoN
  std::string interface;  // resolved interface folder
  bool meta = false;
  bool y8i = false;
};

std::string parent_of(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos || slash == 0 ? std::string("/") : path.substr(0, slash);
}

// Queries one node: metadata node or not, and whether it offers Y8I.
bool probe_node(const SysFs& fs, Sys& sys, VideoNode* node) {
  const std::string dev = fs.host_path("/dev/" + node->name);
  const int fd = sys.open(dev.c_str(), O_RDWR | O_NONBLOCK);
  if (fd < 0) return false;
  v4l2_capability cap{};
  if (sys.ioctl(fd, VIDIOC_QUERYCAP, &cap) < 0) {
    sys.close(fd);
    return false;
  }
  const std::uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  node->meta = (caps & V4L2_CAP_META_CAPTURE) != 0;
  if (!node->meta && (caps & V4L2_CAP_VIDEO_CAPTURE)) {
    for (std::uint32_t i = 0; i < 64; ++i) {
      v4l2_fmtdesc desc{};
      desc.index = i;
      desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      if (sys.ioctl(fd, VIDIOC_ENUM_FMT, &desc) < 0) break;
      if (desc.pixelformat == V4L2_PIX_FMT_Y8I) node->y8i = true;
    }
  }
  sys.close(fd);
  return true;
}

}  // namespace

bool find_d455(const SysFs& fs, Sys& sys, D455Nodes* out, std::string* error) {
  *out = D455Nodes{};
  std::string seen;
  std::vector<VideoNode> nodes;
  for (const std::string& name : fs.list("/sys/class/video4linux")) {
    if (name.compare(0, 5, "video") != 0) continue;
    VideoNode node;
    node.name = name;
    node.number = trailing_number(name);
    const std::string base = "/sys/class/video4linux/" + name;
    const std::string resolved = fs.resolve(base);
    if (resolved.find("virtual") != std::string::npos) continue;
    std::string modalias, mi_text;
    unsigned vid = 0, pid = 0;
    if (!fs.read_text(base + "/device/modalias", &modalias) ||
        !parse_usb_modalias(modalias, &vid, &pid)) {
      seen += " " + name + "(not usb)";
      continue;
    }
    if (vid != kD455Vid || pid != kD455Pid) {
      seen += " " + name + "(" + modalias.substr(4, 10) + ")";
      continue;
    }
    // Interface 0 is the depth function's VideoControl interface: depth, IR and their metadata
    // nodes hang off it; 3 is RGB (notes §1.1).
    if (!fs.read_text(base + "/device/bInterfaceNumber", &mi_text) ||
        std::strtoul(mi_text.c_str(), nullptr, 16) != 0) {
      seen += " " + name + "(d455 mi=" + mi_text + ")";
      continue;
    }
    node.interface = fs.resolve(base + "/device");
    if (!probe_node(fs, sys, &node)) {
      seen += " " + name + "(d455, cannot open/query /dev/" + name + ")";
      continue;
    }
    seen += " " + name + (node.meta ? "(d455 meta)" : node.y8i ? "(d455 Y8I)" : "(d455 no Y8I)");
    nodes.push_back(node);
  }
  std::sort(nodes.begin(), nodes.end(),
            [](const VideoNode& a, const VideoNode& b) { return a.number < b.number; });
  const VideoNode* ir = nullptr;
  for (const auto& n : nodes) {
    if (!n.meta && n.y8i) {
      ir = &n;
      break;
    }
  }
  if (ir == nullptr) {
    *error = "no D455 (8086:0b5c) video node offering Y8I under " + fs.root() +
             "/sys/class/video4linux; seen:" + (seen.empty() ? std::string(" nothing") : seen) +
             " (Y8I needs a USB3 link)";
    return false;
  }
  out->video_path = "/dev/" + ir->name;
  out->usb_device = parent_of(ir->interface);
  // The kernel registers a metadata node right after its video node; require the same interface.
  for (const auto& n : nodes) {
    if (n.meta && n.number > ir->number && n.interface == ir->interface) {
      out->meta_path = "/dev/" + n.name;
      break;
    }
  }
  for (const std::string& name : fs.list("/sys/bus/iio/devices")) {
    if (name.compare(0, 10, "iio:device") != 0) continue;
    const std::string base = "/sys/bus/iio/devices/" + name;
    std::string sensor;
    if (!fs.read_text(base + "/name", &sensor)) continue;
    const std::string resolved = fs.resolve(base);
    if (resolved.compare(0, out->usb_device.size() + 1, out->usb_device + "/") != 0) continue;
    if (sensor == "accel_3d" && out->accel_sysfs.empty()) {
      out->accel_sysfs = base;
      out->accel_dev = "/dev/" + name;
    } else if (sensor == "gyro_3d" && out->gyro_sysfs.empty()) {
      out->gyro_sysfs = base;
      out->gyro_dev = "/dev/" + name;
    }
  }
  return true;
}

}  // namespace ums::d455
