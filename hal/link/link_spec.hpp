#pragma once
// Opens the link a command line names: "udp:HOST:PORT" or "serial:PATH[:BAUD]" (921600 when
// the baud is left out). Throws std::invalid_argument for a malformed spec (saying what the
// forms are) and std::runtime_error when the link cannot be opened.

#include <memory>
#include <string>

#include "hal/link/byte_link.hpp"

namespace ums::hal {

std::unique_ptr<ByteLink> open_link(const std::string& spec);

}  // namespace ums::hal
