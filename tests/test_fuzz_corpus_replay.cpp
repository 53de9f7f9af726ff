// Replays the fuzz seed corpus (tests/fuzz/corpus/<target>/) through the same
// entry points as the libFuzzer targets, in the normal build: every reader of
// outside input must answer every corpus file with a result or an InputError,
// never another exception or a crash. File names say what is expected:
//   valid_*  a well-formed file: the reader must accept it;
//   found_*  an input the fuzzer found crashing or hanging a reader (the
//            regression cases of docs/FUZZING.md): it must not crash;
//   others   hand-made near-valid files: the reader must reject them.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "fuzz/fuzz_entry_points.hpp"
#include "test_support.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;

fs::path corpusDir() { return test::sourceDir() / "tests" / "fuzz" / "corpus"; }

std::string readBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

bool startsWith(const std::string& text, const std::string& prefix) { return text.rfind(prefix, 0) == 0; }

std::vector<std::string> targetNames() {
  std::vector<std::string> names;
  for (const fuzz::FuzzTarget& target : fuzz::fuzzTargets()) names.push_back(target.name);
  return names;
}

const fuzz::FuzzTarget& targetNamed(const std::string& name) {
  for (const fuzz::FuzzTarget& target : fuzz::fuzzTargets())
    if (target.name == name) return target;
  throw std::logic_error("no fuzz target " + name);
}

class FuzzCorpusReplay : public ::testing::TestWithParam<std::string> {};

TEST_P(FuzzCorpusReplay, EveryFileIsAnsweredAsItsNameSays) {
  const fuzz::FuzzTarget& target = targetNamed(GetParam());
  const fs::path dir = corpusDir() / target.name;
  ASSERT_TRUE(fs::is_directory(dir)) << dir;
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.is_regular_file()) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  int valid = 0, rejected = 0;
  for (const fs::path& file : files) {
    const std::string name = file.filename().string();
    const std::string bytes = readBytes(file);
    bool accepted = false;
    ASSERT_NO_THROW(accepted = target.run(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()))
        << file;
    if (startsWith(name, "valid_")) {
      EXPECT_TRUE(accepted) << file << " is a valid file but the reader rejects it";
      ++valid;
    } else if (!startsWith(name, "found_")) {
      EXPECT_FALSE(accepted) << file << " is malformed but the reader accepts it";
      ++rejected;
    }
  }
  // A seed corpus needs both kinds to steer the fuzzer.
  EXPECT_GE(valid, 1) << dir << " has no valid_* seed";
  EXPECT_GE(rejected, 1) << dir << " has no malformed seed";
}

INSTANTIATE_TEST_SUITE_P(Readers, FuzzCorpusReplay, ::testing::ValuesIn(targetNames()),
                         [](const ::testing::TestParamInfo<std::string>& info) { return info.param; });

TEST(FuzzCorpus, EveryCorpusFolderBelongsToATargetAndEveryTargetHasSources) {
  std::set<std::string> targets;
  for (const fuzz::FuzzTarget& target : fuzz::fuzzTargets()) {
    targets.insert(target.name);
    EXPECT_TRUE(fs::exists(test::sourceDir() / "tests" / "fuzz" / ("fuzz_" + target.name + ".cpp"))) << target.name;
  }
  for (const auto& entry : fs::directory_iterator(corpusDir()))
    EXPECT_TRUE(targets.count(entry.path().filename().string())) << entry.path() << " belongs to no fuzz target";
}

}  // namespace
}  // namespace vslam
