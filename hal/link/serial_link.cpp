#include "hal/link/serial_link.hpp"

#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "core/mavlink/frame_v2.hpp"

namespace ums::hal {
namespace {

speed_t speed_of(int baud) {
  switch (baud) {
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    case 230400: return B230400;
    case 460800: return B460800;
    case 500000: return B500000;
    case 921600: return B921600;
    case 1000000: return B1000000;
    case 1500000: return B1500000;
    case 2000000: return B2000000;
    case 3000000: return B3000000;
    default: return B0;
  }
}

}  // namespace

SerialLink::SerialLink(const std::string& path, int baud)
    : bytes_per_s_(baud / 10.0),  // 8N1: 10 bits a byte
      capacity_bytes_(std::max(2.0 * mavlink::kMaxFrameBytes, baud / 10.0 * 0.020)),
      tokens_(capacity_bytes_),
      last_refill_(std::chrono::steady_clock::now()),
      description_("serial:" + path + ":" + std::to_string(baud)) {
  const speed_t speed = speed_of(baud);
  if (speed == B0)
    throw std::runtime_error(description_ + ": baud " + std::to_string(baud) +
                             " not supported (9600, 19200, 38400, 57600, 115200, 230400, 460800, 500000, "
                             "921600, 1000000, 1500000, 2000000, 3000000)");
  fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) throw std::runtime_error(description_ + ": open: " + std::strerror(errno));
  termios tio{};
  if (::tcgetattr(fd_, &tio) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd_);
    throw std::runtime_error(description_ + ": not a terminal (tcgetattr: " + why + ")");
  }
  ::cfmakeraw(&tio);
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_cflag &= ~static_cast<tcflag_t>(CSTOPB | PARENB | CRTSCTS);
  ::cfsetispeed(&tio, speed);
  ::cfsetospeed(&tio, speed);
  if (::tcsetattr(fd_, TCSANOW, &tio) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd_);
    throw std::runtime_error(description_ + ": tcsetattr: " + why);
  }
}

SerialLink::~SerialLink() {
  if (fd_ >= 0) ::close(fd_);
}

void SerialLink::refill() {
  const auto now = std::chrono::steady_clock::now();
  const double dt_s = std::chrono::duration<double>(now - last_refill_).count();
  last_refill_ = now;
  tokens_ = std::min(capacity_bytes_, tokens_ + dt_s * bytes_per_s_);
}

bool SerialLink::flush_pending() {
  if (pending_n_ == 0) return true;
  const ssize_t w = ::write(fd_, pending_, pending_n_);
  if (w > 0) {
    std::memmove(pending_, pending_ + w, pending_n_ - static_cast<std::size_t>(w));
    pending_n_ -= static_cast<std::size_t>(w);
  } else if (w < 0 && errno != EAGAIN && errno != EWOULDBLOCK) {
    ++counters_.errors;
  }
  return pending_n_ == 0;
}

bool SerialLink::send(const std::uint8_t* bytes, std::size_t n) {
  refill();
  if (!flush_pending() || static_cast<double>(n) > tokens_ || n > sizeof(pending_)) {
    ++counters_.packets_dropped;
    return false;
  }
  ssize_t w = ::write(fd_, bytes, n);
  if (w < 0) {
    if (errno != EAGAIN && errno != EWOULDBLOCK) ++counters_.errors;
    ++counters_.packets_dropped;
    return false;
  }
  // A partial write: the rest goes first on the next call, so the frame stays whole.
  const std::size_t rest = n - static_cast<std::size_t>(w);
  std::memcpy(pending_, bytes + w, rest);
  pending_n_ = rest;
  tokens_ -= static_cast<double>(n);
  ++counters_.packets_sent;
  counters_.bytes_sent += n;
  return true;
}

std::size_t SerialLink::receive(std::uint8_t* out, std::size_t cap) {
  const ssize_t got = ::read(fd_, out, cap);
  if (got <= 0) return 0;
  counters_.bytes_received += static_cast<std::uint64_t>(got);
  return static_cast<std::size_t>(got);
}

}  // namespace ums::hal
