#pragma once
// Finds a D455 (USB 8086:0B5C) through sysfs: its IR video node (the interface-0 node offering
// Y8I), the metadata node that follows it, and the accel_3d / gyro_3d IIO devices hanging off the
// same USB device (notes §1.2, §1.3). Start-up only: allocates strings, may throw nothing.

#include <string>

#include "hal/d455/sys.hpp"

namespace ums::d455 {

inline constexpr unsigned kD455Vid = 0x8086;
inline constexpr unsigned kD455Pid = 0x0B5C;

struct D455Nodes {
  std::string usb_device;    // sysfs path of the USB device (rooted, canonical)
  std::string video_path;    // "/dev/videoN": the IR node offering Y8I
  std::string meta_path;     // "/dev/videoM": its UVC metadata node, "" when the kernel has none
  std::string accel_sysfs;   // "/sys/bus/iio/devices/iio:deviceK", "" when absent
  std::string accel_dev;     // "/dev/iio:deviceK"
  std::string gyro_sysfs;
  std::string gyro_dev;
};

// Parses "usb:v8086p0B5Cd..." into vid/pid. False if not a USB modalias.
bool parse_usb_modalias(const std::string& modalias, unsigned* vid, unsigned* pid);

// Fills `out` with the first D455 found. On failure returns false and says why in `error`
// (what was looked at, which check failed). The IMU fields may stay empty (no HID sensor drivers);
// the caller decides whether that is fatal.
bool find_d455(const SysFs& fs, Sys& sys, D455Nodes* out, std::string* error);

}  // namespace ums::d455
