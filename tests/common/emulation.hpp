#pragma once
// Tests that render many images take minutes under qemu (the aarch64 and armhf stages of CI);
// they run on the host, where the code is the same, and say so when skipped.

#include <catch2/catch.hpp>

namespace ums::test {

inline bool skip_heavy_under_emulation() {
#if defined(__aarch64__) || defined(__arm__)
  WARN("rendering-heavy test: host only (minutes under qemu)");
  return true;
#else
  return false;
#endif
}

}  // namespace ums::test
