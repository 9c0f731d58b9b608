#include "core/common/version.hpp"

namespace ums {

const char* version_string() {
#if defined(__aarch64__)
  return "umsvins 0.1.0 (aarch64)";
#elif defined(__arm__)
  return "umsvins 0.1.0 (arm)";
#elif defined(__x86_64__)
  return "umsvins 0.1.0 (x86_64)";
#else
  return "umsvins 0.1.0";
#endif
}

}  // namespace ums
