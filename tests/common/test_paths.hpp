#pragma once
// Where tests find the shared reference data (read-only) and where they may write.

#include <string>

namespace ums::test {

inline std::string shared_dir() { return UMS_SHARED_DIR; }
inline std::string euroc_micro_dir() { return shared_dir() + "/data/euroc/V1_01_easy_micro"; }
inline std::string groundtruth_dir() { return shared_dir() + "/data/euroc/groundtruth"; }

// A fresh folder under the build tree for this test's files.
std::string make_temp_dir(const std::string& name);

}  // namespace ums::test
