// `vslam vocab build` / `vslam vocab info`, run as a user would.
#include <cstdlib>
#include <fstream>
#include <iterator>

#include <sys/wait.h>

#include <gtest/gtest.h>

#include "place_test_support.hpp"
#include "vslam/place/vocabulary.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;

std::string readAll(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Runs the vslam executable; returns its exit status, stdout and stderr in files under `dir`.
int runVslam(const std::string& arguments, const fs::path& dir) {
  const std::string command = (fs::path(VSLAM_BINARY_DIR) / "vslam").string() + " " + arguments + " > " +
                              (dir / "stdout.txt").string() + " 2> " + (dir / "stderr.txt").string();
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// A TUM-like folder: rgb/ with four teddy frames, depth/ with a depth map that must be skipped.
fs::path tinySequence() {
  const fs::path dir = test::scratchDir("place_cmd_sequence");
  fs::create_directories(dir / "rgb");
  fs::create_directories(dir / "depth");
  const std::vector<std::string> frames = test::tumRgbFrames("freiburg3_teddy");
  for (int index : {0, 60, 120, 180}) fs::copy_file(frames[index], dir / "rgb" / fs::path(frames[index]).filename());
  fs::copy_file(test::tumSequence("freiburg3_teddy") / "depth" /
                    fs::directory_iterator(test::tumSequence("freiburg3_teddy") / "depth")->path().filename(),
                dir / "depth" / "0.png");
  return dir;
}

TEST(PlaceVocabCommand, BuildIsReproducibleAndSkipsDepth) {
  const fs::path sequence = tinySequence();
  const fs::path out = test::scratchDir("place_cmd_out");
  const std::string common = "vocab build --images " + sequence.string() + " --branching 4 --depth 2 --seed 5 --out ";
  ASSERT_EQ(runVslam(common + (out / "a" / "voc.vsv").string(), out), 0) << readAll(out / "stderr.txt");
  const std::string summary = readAll(out / "stdout.txt");
  EXPECT_NE(summary.find("images: 4\n"), std::string::npos) << summary;  // not 5: depth/ is skipped
  EXPECT_NE(summary.find("params: k=4 L=2 seed=5"), std::string::npos) << summary;
  EXPECT_NE(readAll(out / "stderr.txt").find("training 100%"), std::string::npos);

  ASSERT_EQ(runVslam(common + (out / "b.vsv").string(), out), 0) << readAll(out / "stderr.txt");
  const std::string first = readAll(out / "a" / "voc.vsv");
  EXPECT_FALSE(first.empty());
  EXPECT_EQ(first, readAll(out / "b.vsv"));

  const Vocabulary vocabulary = Vocabulary::load((out / "b.vsv").string());
  EXPECT_EQ(vocabulary.branching(), 4);
  EXPECT_EQ(vocabulary.depth(), 2);
  EXPECT_LE(vocabulary.wordCount(), 16u);

  ASSERT_EQ(runVslam("vocab info " + (out / "b.vsv").string(), out), 0);
  EXPECT_NE(readAll(out / "stdout.txt").find("words: " + std::to_string(vocabulary.wordCount()) + "\n"),
            std::string::npos);

  // To DBoW2 text and back: the same file but for seed and iterations, which text does not carry.
  ASSERT_EQ(runVslam("vocab convert " + (out / "b.vsv").string() + " " + (out / "b.txt").string() +
                         " --format dbow2-text",
                     out),
            0);
  EXPECT_EQ(readAll(out / "b.txt").rfind("4 2 0 0\n", 0), 0u);
  ASSERT_EQ(runVslam("vocab convert " + (out / "b.txt").string() + " " + (out / "c.vsv").string(), out), 0);
  std::string back = readAll(out / "c.vsv");
  ASSERT_EQ(back.size(), first.size());
  EXPECT_EQ(back.substr(0, 20), first.substr(0, 20));
  EXPECT_EQ(back.substr(28), first.substr(28));  // bytes 20..27: seed and k-means iterations
}

TEST(PlaceVocabCommand, BadInputsAreOneLineErrors) {
  const fs::path out = test::scratchDir("place_cmd_bad");
  EXPECT_EQ(runVslam("vocab build --images /nonexistent/images --out " + (out / "v.vsv").string(), out), 2);
  EXPECT_EQ(readAll(out / "stderr.txt"), "error: /nonexistent/images: no such image file or folder\n");

  const fs::path empty = test::scratchDir("place_cmd_empty");
  EXPECT_EQ(runVslam("vocab build --images " + empty.string() + " --out " + (out / "v.vsv").string(), out), 2);
  EXPECT_NE(readAll(out / "stderr.txt").find(empty.string() + ": folder holds no images (searched recursively, depth/ skipped)"), std::string::npos);

  std::ofstream(out / "not_a_vocabulary.txt") << "hello\n";
  EXPECT_EQ(runVslam("vocab info " + (out / "not_a_vocabulary.txt").string(), out), 2);
  EXPECT_NE(readAll(out / "stderr.txt").find("not_a_vocabulary.txt:1: not a vocabulary"), std::string::npos);
  EXPECT_FALSE(fs::exists(out / "v.vsv"));
}

}  // namespace
}  // namespace vslam
