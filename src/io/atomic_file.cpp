#include "vslam/io/atomic_file.hpp"

#include <filesystem>
#include <system_error>

#include "vslam/core/error.hpp"

namespace vslam {

namespace fs = std::filesystem;

void writeFileAtomically(const std::string& path, const std::function<void(const std::string&)>& write) {
  const fs::path final_path(path);
  const fs::path temporary = final_path.parent_path() / ("." + final_path.filename().string() + ".partial");
  std::error_code ignored;
  try {
    write(temporary.string());
  } catch (...) {
    fs::remove(temporary, ignored);
    throw;
  }
  std::error_code error;
  fs::rename(temporary, final_path, error);
  if (error) {
    fs::remove(temporary, ignored);
    throw InputError(path, 0, "cannot write the file: " + error.message());
  }
}

}  // namespace vslam
