#include "board/host/commands.hpp"

namespace ums::cli {

int run_simulate(const std::vector<std::string>&, std::ostream&, std::ostream& err) {
  err << "umsvins simulate: not implemented yet (simulator, issue 5); nothing was written.\n";
  return kExitNotImplemented;
}

}  // namespace ums::cli
