#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "board/host/commands.hpp"
#include "board/host/host_isa.hpp"

namespace {

// A host build for x86-64-v3 (cmake/UmsHostIsa.cmake) copied to a machine without it would die on
// an illegal instruction somewhere inside a replay; say why instead, before any work.
bool host_isa_supported() {
#if defined(__AVX2__) && defined(__x86_64__)
  if (!ums::cli::host_runs_x86_64_v3()) {
    std::fputs("umsvins: this build is for x86-64-v3 (AVX2, BMI2) and this CPU lacks part of it; configure with "
               "-DUMS_HOST_ISA=baseline\n",
               stderr);
    return false;
  }
#endif
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (!host_isa_supported()) return 1;
  std::vector<std::string> args(argv + 1, argv + argc);
  return ums::cli::run_cli(args, std::cout, std::cerr);
}
