#include <iostream>
#include <string>
#include <vector>

#include "board/host/commands.hpp"

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  return ums::cli::run_cli(args, std::cout, std::cerr);
}
