// The --mavlink argument: the two forms, the default baud, and what a malformed one says.
#include "hal/link/link_spec.hpp"

#include <pty.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <stdexcept>

using ums::hal::open_link;

TEST_CASE("open_link: udp:HOST:PORT and serial:PATH[:BAUD]", "[link]") {
  auto udp = open_link("udp:127.0.0.1:14540");
  CHECK(std::string(udp->description()) == "udp:127.0.0.1:14540");
  int master = -1, slave = -1;
  char name[128];
  REQUIRE(::openpty(&master, &slave, name, nullptr, nullptr) == 0);
  CHECK(std::string(open_link(std::string("serial:") + name)->description()) ==
        std::string("serial:") + name + ":921600");
  CHECK(std::string(open_link(std::string("serial:") + name + ":57600")->description()) ==
        std::string("serial:") + name + ":57600");
  ::close(master);
  ::close(slave);
}

TEST_CASE("open_link: malformed specs say what is wrong and what the forms are", "[link]") {
  CHECK_THROWS_AS(open_link("tcp:1.2.3.4:5760"), std::invalid_argument);
  CHECK_THROWS_WITH(open_link("tcp:1.2.3.4:5760"), Catch::Contains("udp:HOST:PORT"));
  CHECK_THROWS_WITH(open_link("udp:127.0.0.1"), Catch::Contains("no host and port"));
  CHECK_THROWS_WITH(open_link("udp:127.0.0.1:abc"), Catch::Contains("not a number"));
  CHECK_THROWS_WITH(open_link("udp:127.0.0.1:70000"), Catch::Contains("port '70000'"));
  CHECK_THROWS_WITH(open_link("udp::14540"), Catch::Contains("no host"));
  CHECK_THROWS_WITH(open_link("serial:/dev/ttyS0:fast"), Catch::Contains("baud 'fast'"));
  CHECK_THROWS_WITH(open_link("serial:"), Catch::Contains("no device path"));
}
