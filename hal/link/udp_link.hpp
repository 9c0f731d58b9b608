#pragma once
// MAVLink over UDP: one datagram per packet to HOST:PORT from an ephemeral local port (the
// flight controller or mavlink-router answers to it, e.g. TIMESYNC). Non-blocking: a full
// socket buffer or an unreachable peer (ICMP refused) drops the packet and counts it.

#include <cstdint>
#include <string>

#include "hal/link/byte_link.hpp"

namespace ums::hal {

class UdpLink final : public ByteLink {
 public:
  // Resolves host (a name or an address) at start-up; throws std::runtime_error naming it.
  UdpLink(const std::string& host, std::uint16_t port);
  ~UdpLink() override;
  UdpLink(const UdpLink&) = delete;
  UdpLink& operator=(const UdpLink&) = delete;

  bool send(const std::uint8_t* bytes, std::size_t n) override;
  std::size_t receive(std::uint8_t* out, std::size_t cap) override;
  const LinkCounters& counters() const override { return counters_; }
  const char* description() const override { return description_.c_str(); }

 private:
  int fd_ = -1;
  LinkCounters counters_;
  std::string description_;
};

}  // namespace ums::hal
