#pragma once
// MAVLink over a serial port (a UART to the flight controller's TELEM port, or a pty in tests):
// termios raw 8N1 at the given baud, non-blocking. The wire's own rate is enforced here, by a
// token bucket of baud / 10 bytes per second holding at most 20 ms of data (at least two
// frames): a packet that does not fit is dropped and counted rather than queued, so a slow link
// never holds a pose back behind older ones and never blocks the estimator. A pty ignores the
// baud, which is why the rate is not left to the kernel.

#include <chrono>
#include <cstdint>
#include <string>

#include "hal/link/byte_link.hpp"

namespace ums::hal {

class SerialLink final : public ByteLink {
 public:
  // Opens and configures the device; throws std::runtime_error naming the path, or the baud
  // when it is not one termios has.
  SerialLink(const std::string& path, int baud);
  ~SerialLink() override;
  SerialLink(const SerialLink&) = delete;
  SerialLink& operator=(const SerialLink&) = delete;

  bool send(const std::uint8_t* bytes, std::size_t n) override;
  std::size_t receive(std::uint8_t* out, std::size_t cap) override;
  const LinkCounters& counters() const override { return counters_; }
  const char* description() const override { return description_.c_str(); }
  double bucket_capacity_bytes() const { return capacity_bytes_; }

 private:
  void refill();
  bool flush_pending();

  int fd_ = -1;
  double bytes_per_s_;
  double capacity_bytes_;
  double tokens_;
  std::chrono::steady_clock::time_point last_refill_;
  std::uint8_t pending_[512] = {};  // the tail of a packet the kernel took only in part
  std::size_t pending_n_ = 0;
  LinkCounters counters_;
  std::string description_;
};

}  // namespace ums::hal
