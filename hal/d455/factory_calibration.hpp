#pragma once
// Factory calibration of the IR pair read from the device without librealsense, through the D4xx
// "hardware monitor" (HWM) command tunnel over the depth extension unit (unit 3, selector 1,
// 1024-byte UVC_SET_CUR then UVC_GET_CUR on the IR node; notes §3.3), command GETINTCAL (0x15) with
// table 25 = the stereo coefficients table (notes §5.1, §5.2):
//   header {u16 version, u16 type, u32 size, u32 param, u32 crc32 of the `size` bytes after it},
//   baseline float mm at byte 160, rectified {fx, fy, ppx, ppy} floats per resolution at 256.
// Y8I is rectified, so these intrinsics (zero distortion) and the baseline are all the stereo pair
// needs. Layouts are [V] from the notes; the tunnel's reply framing is [U] until run on a unit,
// so every reply is length- and CRC-checked and a failure leaves the caller's calibration alone.

#include <cstddef>
#include <cstdint>
#include <string>

#include "core/common/calibration.hpp"
#include "core/common/status.hpp"
#include "hal/d455/sys.hpp"

namespace ums::d455 {

inline constexpr std::size_t kHwmBufferBytes = 1024;
inline constexpr std::uint32_t kHwmGetIntCal = 0x15;
inline constexpr std::uint32_t kStereoCoefficientsTable = 25;

// Standard CRC-32 (zlib: polynomial 0xEDB88320, init and final xor 0xFFFFFFFF).
std::uint32_t crc32(const std::uint8_t* data, std::size_t size);

// HWM request: {u16 length = 20 + data, u16 magic 0xCDAB, u32 opcode, u32 p1..p4, data}, zero
// padded to 1024 bytes. False if data does not fit.
bool hwm_build_request(std::uint32_t opcode, const std::uint32_t params[4], const std::uint8_t* data,
                       std::size_t data_size, std::uint8_t out[kHwmBufferBytes]);

// HWM reply: u32 opcode echo (a negative value is a device error code), payload; the payload
// length is taken from the u32 at byte 1020 (notes §3.3) minus the 4-byte echo. kIoError on a
// mismatching echo or a length that does not fit.
Status hwm_parse_reply(const std::uint8_t reply[kHwmBufferBytes], std::uint32_t opcode,
                       const std::uint8_t** payload, std::size_t* payload_size, std::string* error);

struct StereoFactoryCalibration {
  double fx = 0, fy = 0, cx = 0, cy = 0;  // px, rectified, at the requested resolution
  double baseline_m = 0;                  // m, |left-right distance|
};

// Parses a coefficients table (header included) for width x height (entries for 1920x1080,
// 1280x720, 640x480, 848x480, 640x360, 424x240, 320x240, 480x270, 1280x800, 960x540, 640x400,
// 576x576, 720x720, 1152x1152). kInvalidInput with a message on size, CRC or value problems;
// kUnsupported for a resolution without an entry.
Status parse_stereo_coefficients(const std::uint8_t* table, std::size_t size, int width, int height,
                                 StereoFactoryCalibration* out, std::string* error);

// Runs GETINTCAL 25 over the tunnel on `video_path` (the IR node) and parses it.
Status read_stereo_factory_calibration(Sys& sys, const std::string& video_path, int width, int height,
                                       StereoFactoryCalibration* out, std::string* error);

// Puts factory intrinsics and baseline into a rig (both cameras, zero distortion, cam1 at
// +baseline along cam0's x); leaves the IMU extrinsics (CAD or Kalibr) as they are.
void apply_stereo_factory_calibration(const StereoFactoryCalibration& factory, RigCalibration* rig);

}  // namespace ums::d455
