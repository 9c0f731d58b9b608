#include "tests/common/test_paths.hpp"

#include <filesystem>

namespace ums::test {

std::string make_temp_dir(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::path(UMS_TEST_TMP_DIR) / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

}  // namespace ums::test
