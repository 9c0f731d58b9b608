#pragma once
// The D455 IR stereo pair over V4L2: Y8I format negotiation, a fixed set of mmap buffers, poll +
// DQBUF, de-interleave into two preallocated images, driver monotonic timestamps refined by the
// UVC metadata node's device timestamps when present, and the IR controls (emitter, exposure,
// gain) through the depth extension unit (notes §2, §3).
//
// Start-up (open/start) allocates and may return errors with a message; the per-frame path
// (try_dequeue/next) allocates nothing and returns Status values.

#include <poll.h>

#include <cstdint>
#include <memory>
#include <string>

#include "core/common/capacity.hpp"
#include "core/common/status.hpp"
#include "core/common/stereo_frame.hpp"
#include "hal/d455/sys.hpp"
#include "hal/d455/time_base.hpp"
#include "hal/d455/uvc_metadata.hpp"

namespace ums::d455 {

struct CameraOptions {
  int width = 848;                 // px; 640 or 848 (height 480)
  int height = 480;                // px
  int fps = 30;                    // frames per second; 15, 30, 60 or 90
  int buffer_count = 4;            // mmap buffers requested, 2..capacity::kD455MaxV4l2Buffers
  bool emitter_off = true;         // the dot projector would be tracked as static features
  bool auto_exposure = false;      // true: firmware AE; false: exposure_us and gain below
  int exposure_us = 8000;          // µs, 1..200000 (XU selector 3), ignored with auto_exposure
  int gain = 16;                   // UVC gain 16..248; -1 leaves the device's value
  bool use_metadata = true;        // open the metadata node when discovery found one
  bool use_device_timestamps = true;  // map PTS - sensor offset (mid-exposure) to host time
  int control_retries = 3;         // XU writes fail transiently on some ARM hosts (notes §7.8)
  void validate() const;           // throws std::runtime_error naming the field and value
};

// Per-frame detail the StereoFrame does not carry.
struct FrameInfo {
  std::uint32_t v4l2_sequence = 0;
  std::int64_t driver_ns = 0;       // v4l2_buffer.timestamp (CLOCK_MONOTONIC), ns
  bool has_device_time = false;
  std::int64_t device_mid_exposure_us = 0;  // unwrapped device clock, µs
  std::uint32_t exposure_us = 0;
  int emitter_mode = -1;            // -1 unknown, 0 off
};

struct CameraStats {
  std::uint64_t frames = 0;              // delivered
  std::uint64_t timeouts = 0;            // poll returned nothing within the timeout
  std::uint64_t bad_frames = 0;          // V4L2_BUF_FLAG_ERROR or short bytesused: dropped
  std::uint64_t sequence_gaps = 0;       // frames the driver skipped (v4l2 sequence jumps)
  std::uint64_t out_of_order = 0;        // sequence or timestamp going back: dropped
  std::uint64_t duplicates = 0;          // same timestamp twice: dropped
  std::uint64_t meta_unmatched = 0;      // metadata buffers without their frame, or malformed
  std::uint64_t control_failures = 0;    // controls the device refused at start
};

class V4l2Camera {
 public:
  V4l2Camera(Sys& sys, const CameraOptions& options, DeviceClockMap* clock);
  ~V4l2Camera();
  V4l2Camera(const V4l2Camera&) = delete;
  V4l2Camera& operator=(const V4l2Camera&) = delete;

  // Opens and configures the nodes (paths as given to Sys::open; meta_path may be empty).
  // kUnsupported when the node refuses Y8I at the requested size/rate, kIoError for device errors;
  // `error` then names the node, the request and the answer.
  Status open(const std::string& video_path, const std::string& meta_path, std::string* error);
  // Queues every buffer and starts streaming (metadata node first).
  Status start(std::string* error);
  // STREAMOFF both nodes; buffers stay mapped so start() may follow again.
  void stop();
  // stop + start: the recovery for a stalled stream.
  Status restart(std::string* error);
  void close();

  // Non-blocking: consumes whatever the driver has ready. kOk with a new frame in `frame` (its
  // views stay valid until the second-next delivered frame: two output slots alternate), kEmpty
  // when nothing is ready, kIoError when the device is gone (ENODEV: unplugged).
  Status try_dequeue(StereoFrame* frame, FrameInfo* info);
  // Blocking variant: polls up to timeout_ms; kTimeout when the stream stalls.
  Status next(StereoFrame* frame, FrameInfo* info, int timeout_ms);

  // Descriptors for an outer poll loop (video first, then metadata if open), and how many.
  int poll_fds(pollfd* fds, int max) const;
  bool disconnected() const { return disconnected_; }
  const CameraStats& stats() const { return stats_; }
  const CameraOptions& options() const { return options_; }
  int buffer_count() const { return video_.count; }
  std::uint32_t meta_format() const { return meta_format_; }  // 'D4XX', 'UVCH' or 0

 private:
  struct Node {
    int fd = -1;
    std::uint32_t type = 0;
    int count = 0;
    void* ptr[capacity::kD455MaxV4l2Buffers] = {};
    std::size_t len[capacity::kD455MaxV4l2Buffers] = {};
  };
  Status map_buffers(Node* node, int count, std::string* error, const char* what);
  void unmap(Node* node);
  Status queue_all(Node* node);
  Status requeue(Node* node, std::uint32_t index);
  void drain_meta();
  void apply_controls(std::string* error);
  bool xu_set(std::uint8_t selector, const void* data, std::uint16_t size);

  Sys& sys_;
  CameraOptions options_;
  DeviceClockMap* clock_;
  Node video_;
  Node meta_;
  std::uint32_t meta_format_ = 0;
  std::uint32_t sizeimage_ = 0;
  std::uint32_t bytesperline_ = 0;
  bool streaming_ = false;
  bool disconnected_ = false;
  std::unique_ptr<std::uint8_t[]> planes_;  // 2 slots x (left, right), allocated at open
  int slot_ = 0;
  bool have_sequence_ = false;
  std::uint32_t last_sequence_ = 0;
  std::uint64_t delivered_ = 0;
  struct MetaEntry {
    std::uint32_t sequence = 0;
    UvcFrameMeta meta;
    bool used = true;
  };
  MetaEntry pending_meta_[capacity::kD455MaxPendingMeta];
  OrderGate gate_;
  CameraStats stats_;
};

}  // namespace ums::d455
