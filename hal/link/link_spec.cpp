#include "hal/link/link_spec.hpp"

#include <stdexcept>

#include "hal/link/serial_link.hpp"
#include "hal/link/udp_link.hpp"

namespace ums::hal {
namespace {

int parse_int(const std::string& text, int lo, int hi, const std::string& spec, const char* what) {
  std::size_t used = 0;
  int v = 0;
  try {
    v = std::stoi(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty() || v < lo || v > hi)
    throw std::invalid_argument("link '" + spec + "': " + what + " '" + text + "' is not a number in " +
                                std::to_string(lo) + ".." + std::to_string(hi));
  return v;
}

}  // namespace

std::unique_ptr<ByteLink> open_link(const std::string& spec) {
  const char* forms = " (forms: udp:HOST:PORT, serial:PATH[:BAUD])";
  if (spec.rfind("udp:", 0) == 0) {
    const std::string rest = spec.substr(4);
    const std::size_t colon = rest.rfind(':');
    if (colon == std::string::npos || colon == 0)
      throw std::invalid_argument("link '" + spec + "': no host and port" + forms);
    const int port = parse_int(rest.substr(colon + 1), 1, 65535, spec, "port");
    return std::make_unique<UdpLink>(rest.substr(0, colon), static_cast<std::uint16_t>(port));
  }
  if (spec.rfind("serial:", 0) == 0) {
    std::string path = spec.substr(7);
    int baud = 921600;
    const std::size_t colon = path.rfind(':');
    if (colon != std::string::npos) {
      baud = parse_int(path.substr(colon + 1), 1, 4000000, spec, "baud");
      path = path.substr(0, colon);
    }
    if (path.empty()) throw std::invalid_argument("link '" + spec + "': no device path" + forms);
    return std::make_unique<SerialLink>(path, baud);
  }
  throw std::invalid_argument("link '" + spec + "': unknown kind" + forms);
}

}  // namespace ums::hal
