#include "hal/d455/thread_bridge.hpp"

#include <cstring>
#include <stdexcept>
#include <string>

namespace ums::d455 {

ThreadBridge::ThreadBridge(int max_width, int max_height) : max_width_(max_width), max_height_(max_height) {
  if (max_width < 1 || max_height < 1 || max_width > capacity::kMaxImageWidth || max_height > capacity::kMaxImageHeight) {
    throw std::invalid_argument("ThreadBridge: image size " + std::to_string(max_width) + "x" +
                                std::to_string(max_height) + " outside 1.." + std::to_string(capacity::kMaxImageWidth) +
                                " x 1.." + std::to_string(capacity::kMaxImageHeight));
  }
  const std::size_t plane = static_cast<std::size_t>(max_width) * static_cast<std::size_t>(max_height);
  pixels_.reset(new std::uint8_t[2 * kSlots * plane]());
  for (std::size_t i = 0; i < kSlots; ++i) free_slots_.push(static_cast<int>(i));
}

void ThreadBridge::on_imu(const ImuSample& sample) {
  Event e;
  e.imu = sample;
  if (events_.push(e) != Status::kOk) imu_dropped_.fetch_add(1, std::memory_order_relaxed);
}

void ThreadBridge::on_stereo(const StereoFrame& frame) {
  int slot = spare_slot_;
  spare_slot_ = -1;
  if (!frame.left.valid() || frame.left.width > max_width_ || frame.left.height > max_height_ ||
      (slot < 0 && free_slots_.pop(&slot) != Status::kOk)) {
    spare_slot_ = slot;
    frames_dropped_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  const std::size_t plane = static_cast<std::size_t>(max_width_) * static_cast<std::size_t>(max_height_);
  std::uint8_t* left = pixels_.get() + 2 * static_cast<std::size_t>(slot) * plane;
  std::uint8_t* right = left + plane;
  const bool has_right = frame.right.valid() && frame.right.width == frame.left.width &&
                         frame.right.height == frame.left.height;
  for (int y = 0; y < frame.left.height; ++y) {
    std::memcpy(left + static_cast<std::size_t>(y) * static_cast<std::size_t>(frame.left.width), frame.left.row(y),
                static_cast<std::size_t>(frame.left.width));
    if (has_right) {
      std::memcpy(right + static_cast<std::size_t>(y) * static_cast<std::size_t>(frame.left.width),
                  frame.right.row(y), static_cast<std::size_t>(frame.left.width));
    }
  }
  Event e;
  e.is_frame = true;
  e.slot = slot;
  e.t_ns = frame.t_ns;
  e.seq = frame.seq;
  e.width = frame.left.width;
  e.height = frame.left.height;
  e.has_right = has_right;
  if (events_.push(e) != Status::kOk) {
    spare_slot_ = slot;  // kept by the producer: free_slots_ has the consumer as its only pusher
    frames_dropped_.fetch_add(1, std::memory_order_relaxed);
  }
}

std::size_t ThreadBridge::drain(MeasurementSink& sink, std::size_t max_events) {
  std::size_t n = 0;
  Event e;
  while (n < max_events && events_.pop(&e) == Status::kOk) {
    ++n;
    if (!e.is_frame) {
      sink.on_imu(e.imu);
      continue;
    }
    const std::size_t plane = static_cast<std::size_t>(max_width_) * static_cast<std::size_t>(max_height_);
    const std::uint8_t* left = pixels_.get() + 2 * static_cast<std::size_t>(e.slot) * plane;
    StereoFrame f;
    f.t_ns = e.t_ns;
    f.seq = e.seq;
    f.left = ImageView{left, e.width, e.height, e.width};
    if (e.has_right) f.right = ImageView{left + plane, e.width, e.height, e.width};
    sink.on_stereo(f);
    free_slots_.push(e.slot);
  }
  return n;
}

}  // namespace ums::d455
