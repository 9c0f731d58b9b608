// UDP to a receiver on 127.0.0.1: whole packets arrive as datagrams, the receiver's answer comes
// back through receive(), and a port nobody listens on makes drops, not errors or blocking.
#include "hal/link/udp_link.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cstring>
#include <thread>

using ums::hal::UdpLink;

namespace {

struct Receiver {
  int fd = -1;
  std::uint16_t port = 0;
  Receiver() {
    fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    REQUIRE(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)) == 0);
    socklen_t len = sizeof(a);
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    port = ntohs(a.sin_port);
    timeval tv{2, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));
  }
  ~Receiver() { ::close(fd); }
};

}  // namespace

TEST_CASE("UdpLink: a packet arrives whole as one datagram and the answer comes back", "[link]") {
  Receiver rx;
  UdpLink link("127.0.0.1", rx.port);
  std::uint8_t packet[245];
  for (std::size_t i = 0; i < sizeof(packet); ++i) packet[i] = static_cast<std::uint8_t>(i * 7);
  REQUIRE(link.send(packet, sizeof(packet)));
  std::uint8_t got[1024];
  sockaddr_in from{};
  socklen_t from_len = sizeof(from);
  const ssize_t n = ::recvfrom(rx.fd, got, sizeof(got), 0, reinterpret_cast<sockaddr*>(&from), &from_len);
  REQUIRE(n == static_cast<ssize_t>(sizeof(packet)));
  CHECK(std::memcmp(got, packet, sizeof(packet)) == 0);
  CHECK(link.counters().packets_sent == 1);
  CHECK(link.counters().bytes_sent == sizeof(packet));

  const std::uint8_t answer[] = {0xFD, 1, 2, 3};
  REQUIRE(::sendto(rx.fd, answer, sizeof(answer), 0, reinterpret_cast<sockaddr*>(&from), from_len) == 4);
  std::uint8_t back[64];
  std::size_t m = 0;
  for (int i = 0; i < 200 && m == 0; ++i) {  // loopback delivery is immediate; allow a scheduler slice
    m = link.receive(back, sizeof(back));
    if (m == 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  REQUIRE(m == 4);
  CHECK(std::memcmp(back, answer, 4) == 0);
  CHECK(link.receive(back, sizeof(back)) == 0);  // nothing more: returns at once
}

TEST_CASE("UdpLink: nobody listening drops packets and never blocks", "[link]") {
  std::uint16_t port = 0;
  {
    Receiver closed;  // bind a port, then free it: nothing listens there afterwards
    port = closed.port;
  }
  UdpLink link("127.0.0.1", port);
  const std::uint8_t packet[100] = {};
  int accepted = 0;
  for (int i = 0; i < 50; ++i) accepted += link.send(packet, sizeof(packet)) ? 1 : 0;
  // The first datagram leaves; the ICMP "port unreachable" it provokes turns later sends into
  // ECONNREFUSED, which the link counts as drops.
  CHECK(link.counters().packets_sent + link.counters().packets_dropped == 50);
  CHECK(link.counters().packets_dropped >= 1);
  CHECK(link.counters().errors == 0);
  CHECK(accepted == static_cast<int>(link.counters().packets_sent));
}

TEST_CASE("UdpLink: an unknown host is refused at start-up with its name", "[link]") {
  try {
    UdpLink link("no-such-host.invalid", 14540);
    FAIL("expected an exception");
  } catch (const std::runtime_error& e) {
    CHECK(std::string(e.what()).find("no-such-host.invalid") != std::string::npos);
  }
}
