#include <cstdio>

#include "core/common/version.hpp"

int main() {
  std::printf("%s\n", ums::version_string());
  return 0;
}
