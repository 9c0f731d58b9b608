// The serial path through a pseudo-terminal pair: raw bytes arrive unchanged, and the link keeps
// to its baud rate by dropping whole packets (a pty itself would take them at any speed).
#include "hal/link/serial_link.hpp"

#include <fcntl.h>
#include <pty.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <chrono>
#include <cstring>
#include <thread>
#include <vector>

using ums::hal::SerialLink;

namespace {

struct Pty {
  int master = -1, slave = -1;
  std::string slave_path;
  Pty() {
    char name[128];
    REQUIRE(::openpty(&master, &slave, name, nullptr, nullptr) == 0);
    slave_path = name;
    ::fcntl(master, F_SETFL, O_NONBLOCK);
  }
  ~Pty() {
    ::close(master);
    ::close(slave);
  }
  std::vector<std::uint8_t> drain() {
    std::vector<std::uint8_t> all;
    std::uint8_t buf[4096];
    for (int idle = 0; idle < 20;) {
      const ssize_t n = ::read(master, buf, sizeof(buf));
      if (n > 0) {
        all.insert(all.end(), buf, buf + n);
        idle = 0;
      } else {
        ++idle;
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
      }
    }
    return all;
  }
};

std::vector<std::uint8_t> packet_of(std::size_t n, std::uint8_t tag) {
  std::vector<std::uint8_t> p(n);
  for (std::size_t i = 0; i < n; ++i) p[i] = static_cast<std::uint8_t>(tag + i);
  p[0] = 0xFD;
  return p;
}

}  // namespace

TEST_CASE("SerialLink: bytes reach the other end of a pty unchanged, raw (no newline mangling)", "[link]") {
  Pty pty;
  SerialLink link(pty.slave_path, 921600);
  std::vector<std::uint8_t> sent;
  for (std::uint8_t tag : {0x0A, 0x0D, 0x03}) {  // LF, CR, ^C: a cooked terminal would change them
    const auto p = packet_of(60, tag);
    REQUIRE(link.send(p.data(), p.size()));
    sent.insert(sent.end(), p.begin(), p.end());
  }
  CHECK(pty.drain() == sent);
  CHECK(link.counters().packets_dropped == 0);
}

TEST_CASE("SerialLink at 57600 baud: a burst beyond 20 ms of wire time is dropped whole and counted", "[link]") {
  Pty pty;
  SerialLink link(pty.slave_path, 57600);
  // 5760 B/s; the bucket holds max(2 frames of 267 B, 20 ms) = 534 B: two 245-byte ODOMETRY frames.
  CHECK(link.bucket_capacity_bytes() == Approx(534.0));
  const auto p = packet_of(245, 1);
  const auto t0 = std::chrono::steady_clock::now();
  int sent = 0;
  for (int i = 0; i < 30; ++i) sent += link.send(p.data(), p.size()) ? 1 : 0;
  const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // However slowly this machine ran the loop, the link cannot have passed more than its bucket
  // plus the wire's rate over the elapsed time.
  const double budget = (534.0 + 5760.0 * elapsed_s) / 245.0;
  CHECK(sent >= 2);
  CHECK(sent <= static_cast<int>(budget) + 1);
  CHECK(link.counters().packets_sent == static_cast<std::uint64_t>(sent));
  CHECK(link.counters().packets_dropped == static_cast<std::uint64_t>(30 - sent));
  const auto got = pty.drain();
  CHECK(got.size() == static_cast<std::size_t>(sent) * p.size());  // only whole packets went out
  // After 100 ms of quiet the wire has room for two frames again.
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  CHECK(link.send(p.data(), p.size()));
}

TEST_CASE("SerialLink: a baud termios does not have and a missing device are refused with their names", "[link]") {
  Pty pty;
  CHECK_THROWS_WITH(SerialLink(pty.slave_path, 12345), Catch::Contains("baud 12345 not supported"));
  CHECK_THROWS_WITH(SerialLink("/dev/no-such-tty", 921600), Catch::Contains("/dev/no-such-tty"));
  CHECK_THROWS_WITH(SerialLink("/dev/null", 921600), Catch::Contains("not a terminal"));
}
