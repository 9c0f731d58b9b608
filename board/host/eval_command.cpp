#include "board/host/commands.hpp"

namespace ums::cli {

int run_eval(const std::vector<std::string>&, std::ostream&, std::ostream& err) {
  err << "umsvins eval: not implemented yet (evaluation, issue 5).\n";
  return kExitNotImplemented;
}

}  // namespace ums::cli
