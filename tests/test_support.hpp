#pragma once
// Paths the tests need. ../shared (beside the project root) holds the real
// sequences and models; tests that need it fail, not skip, when it is missing,
// so a CI run without data cannot pass silently.
#include <cstdlib>
#include <filesystem>
#include <string>

namespace vslam::test {

inline std::filesystem::path sourceDir() { return VSLAM_SOURCE_DIR; }

inline std::filesystem::path sharedDir() {
  if (const char* env = std::getenv("VSLAM_SHARED")) return env;
  return sourceDir().parent_path() / "shared";
}

inline std::filesystem::path sharedData() { return sharedDir() / "data"; }
inline std::filesystem::path sharedModels() { return sharedDir() / "models"; }
inline std::filesystem::path tumSequence(const std::string& name) {
  return sharedData() / "tum" / ("rgbd_dataset_" + name);
}

// A fresh, empty scratch directory under the build tree.
inline std::filesystem::path scratchDir(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::path(VSLAM_BINARY_DIR) / "test_scratch" / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace vslam::test
