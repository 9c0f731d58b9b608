#pragma once
// A datagram-or-stream byte link to another device (a flight controller), never blocking the
// caller: what cannot go out now is dropped whole and counted, never half-sent.

#include <cstddef>
#include <cstdint>

namespace ums::hal {

struct LinkCounters {
  std::uint64_t packets_sent = 0;
  std::uint64_t bytes_sent = 0;
  std::uint64_t packets_dropped = 0;  // the link was full or down: not sent
  std::uint64_t bytes_received = 0;
  std::uint64_t errors = 0;           // send/receive failures other than "full"
};

class ByteLink {
 public:
  virtual ~ByteLink() = default;
  // Sends one whole packet or drops it (false). Never blocks.
  virtual bool send(const std::uint8_t* bytes, std::size_t n) = 0;
  // Reads what has arrived, up to cap bytes; 0 when nothing. Never blocks.
  virtual std::size_t receive(std::uint8_t* out, std::size_t cap) = 0;
  virtual const LinkCounters& counters() const = 0;
  // "udp:127.0.0.1:14540", "serial:/dev/ttyS1:921600".
  virtual const char* description() const = 0;
};

}  // namespace ums::hal
