#pragma once
// One exception type for bad input. Its message is a single line that names the
// file, the line where there is one, and what is wrong; `vslam` prints it and
// exits non-zero.
#include <stdexcept>
#include <string>

namespace vslam {

class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(message) {}
  // "FILE:LINE: WHAT" (LINE omitted when <= 0).
  InputError(const std::string& file, int line, const std::string& what)
      : std::runtime_error(format(file, line, what)) {}

  static std::string format(const std::string& file, int line, const std::string& what) {
    return line > 0 ? file + ":" + std::to_string(line) + ": " + what : file + ": " + what;
  }
};

}  // namespace vslam
