#pragma once
// Helpers for the tests that run the built `vslam` binary end to end, as a
// user would: from the project root, with no $VSLAM_DATA, stdout and stderr
// captured in files.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "test_support.hpp"

namespace vslam::test {

struct CliOutcome {
  int exit_code = -1;
  std::string out, err;
};

inline std::string quoted(const std::string& text) { return "'" + text + "'"; }

inline std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

inline bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// Lines of stderr that are not spdlog's "[hh:mm:ss.mmm] [level] ..." logs.
inline std::vector<std::string> errorLines(const std::string& err) {
  std::vector<std::string> lines;
  std::istringstream in(err);
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line[0] != '[') lines.push_back(line);
  return lines;
}

inline std::string vslamBinary() { return quoted(std::string(VSLAM_BINARY_DIR) + "/vslam"); }

// Runs `command` (a shell command line) from the project root with no
// $VSLAM_DATA, stdout and stderr into `dir`.
inline CliOutcome runFromProjectRoot(const std::string& command, const std::filesystem::path& dir) {
  const std::string line = "cd " + quoted(sourceDir().string()) + " && env -u VSLAM_DATA " + command + " > " +
                           quoted((dir / "out").string()) + " 2> " + quoted((dir / "err").string());
  const int status = std::system(line.c_str());
  CliOutcome outcome;
  outcome.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  outcome.out = slurp(dir / "out");
  outcome.err = slurp(dir / "err");
  return outcome;
}

// `vslam ARGS` run from the project root, output into `dir`.
inline CliOutcome runVslam(const std::string& args, const std::filesystem::path& dir) {
  return runFromProjectRoot(vslamBinary() + " " + args, dir);
}

// A fresh scratch folder for one call of the current test (ctest may run a
// file's tests in parallel, and suites may share test names).
inline std::filesystem::path callDir(const std::string& prefix) {
  static int call = 0;
  const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
  return scratchDir(prefix + info->test_suite_name() + "_" + info->name() + "_" + std::to_string(++call));
}

}  // namespace vslam::test
