#include "hal/link/udp_link.hpp"

#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace ums::hal {

UdpLink::UdpLink(const std::string& host, std::uint16_t port)
    : description_("udp:" + host + ":" + std::to_string(port)) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* found = nullptr;
  const int rc = ::getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &found);
  if (rc != 0 || found == nullptr)
    throw std::runtime_error(description_ + ": cannot resolve '" + host + "': " + ::gai_strerror(rc));
  fd_ = ::socket(found->ai_family, found->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, found->ai_protocol);
  const int saved = errno;
  if (fd_ >= 0 && ::connect(fd_, found->ai_addr, found->ai_addrlen) != 0) {
    const std::string why = std::strerror(errno);
    ::freeaddrinfo(found);
    ::close(fd_);
    fd_ = -1;
    throw std::runtime_error(description_ + ": connect: " + why);
  }
  ::freeaddrinfo(found);
  if (fd_ < 0) throw std::runtime_error(description_ + ": socket: " + std::strerror(saved));
}

UdpLink::~UdpLink() {
  if (fd_ >= 0) ::close(fd_);
}

bool UdpLink::send(const std::uint8_t* bytes, std::size_t n) {
  const ssize_t sent = ::send(fd_, bytes, n, MSG_DONTWAIT | MSG_NOSIGNAL);
  if (sent == static_cast<ssize_t>(n)) {
    ++counters_.packets_sent;
    counters_.bytes_sent += n;
    return true;
  }
  // EAGAIN: the socket buffer is full; ECONNREFUSED: nobody listens (yet). Both: drop.
  if (sent < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != ECONNREFUSED) ++counters_.errors;
  ++counters_.packets_dropped;
  return false;
}

std::size_t UdpLink::receive(std::uint8_t* out, std::size_t cap) {
  const ssize_t got = ::recv(fd_, out, cap, MSG_DONTWAIT);
  if (got <= 0) return 0;  // nothing, or an ICMP error reported late
  counters_.bytes_received += static_cast<std::uint64_t>(got);
  return static_cast<std::size_t>(got);
}

}  // namespace ums::hal
