// `vslam vocab build` / `vslam vocab info`, run as a user would.
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>

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

// A DBoW2 text vocabulary as DBoW2 writes one: nodes numbered in the order
// DBoW2 creates them (all children of a node, then the first child's subtree:
// not breadth-first), a branch that ends above the deepest level, inner nodes
// of weight 0, weights printed with six significant digits.
std::string dbow2WrittenText() {
  struct Line {
    int parent;
    bool leaf;
    const char* weight;
  };
  const Line lines[] = {{0, false, "0"},       {0, true, "0.5"},        {0, false, "0"},       {1, false, "0"},
                        {1, true, "1.20397"},  {4, true, "2.30259"},    {4, true, "0"},        {3, true, "0.693147"},
                        {3, true, "1.79176"},  {3, true, "3.13549"}};
  std::ostringstream text;
  text << "3 3  0 0\n";  // k L, scoring L1, weighting TF-IDF (ORB-SLAM's header has the double space)
  int node = 1;
  for (const Line& line : lines) {
    text << line.parent << " " << (line.leaf ? 1 : 0) << " ";
    for (int b = 0; b < 32; ++b) text << (node * 37 + b * 11) % 256 << " ";
    text << line.weight << "\n";
    ++node;
  }
  return text.str();
}

// Every node of a DBoW2 text file keyed by its place in the tree (the child
// indices from the root, children in file order), so that two files that
// number their nodes differently compare node by node.
struct Dbow2Node {
  bool leaf = false;
  std::vector<int> descriptor;
  double weight = 0;
  bool operator==(const Dbow2Node& o) const { return leaf == o.leaf && descriptor == o.descriptor && weight == o.weight; }
};
std::map<std::vector<int>, Dbow2Node> dbow2Tree(const std::string& text, std::string& header) {
  std::istringstream in(text);
  std::getline(in, header);
  std::vector<std::vector<int>> path_of_node{{}};  // node 0: the root
  std::vector<int> children_of_node{0};
  std::map<std::vector<int>, Dbow2Node> tree;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    int parent = 0, leaf = 0;
    Dbow2Node node;
    fields >> parent >> leaf;
    node.leaf = leaf == 1;
    node.descriptor.resize(32);
    for (int& d : node.descriptor) fields >> d;
    fields >> node.weight;
    EXPECT_TRUE(fields && parent < static_cast<int>(path_of_node.size())) << line;
    if (!fields || parent >= static_cast<int>(path_of_node.size())) break;
    std::vector<int> path = path_of_node[parent];
    path.push_back(children_of_node[parent]++);
    path_of_node.push_back(path);
    children_of_node.push_back(0);
    tree[path] = node;
  }
  return tree;
}

TEST(PlaceVocabCommand, Dbow2TextToBinaryAndBackKeepsEveryNode) {
  const fs::path out = test::scratchDir("place_cmd_dbow2_round_trip");
  const std::string original = dbow2WrittenText();
  std::ofstream(out / "in.txt") << original;
  ASSERT_EQ(runVslam("vocab convert " + (out / "in.txt").string() + " " + (out / "mid.vsv").string(), out), 0)
      << readAll(out / "stderr.txt");
  ASSERT_EQ(runVslam("vocab convert " + (out / "mid.vsv").string() + " " + (out / "back.txt").string() +
                         " --format dbow2-text",
                     out),
            0)
      << readAll(out / "stderr.txt");
  ASSERT_EQ(runVslam("vocab info " + (out / "mid.vsv").string(), out), 0);
  EXPECT_NE(readAll(out / "stdout.txt").find("words: 7\n"), std::string::npos) << readAll(out / "stdout.txt");

  std::string header_in, header_back;
  const auto tree_in = dbow2Tree(original, header_in);
  const auto tree_back = dbow2Tree(readAll(out / "back.txt"), header_back);
  EXPECT_EQ(header_back, "3 3 0 0");
  ASSERT_EQ(tree_in.size(), 10u);
  ASSERT_EQ(tree_back.size(), tree_in.size());
  for (const auto& [path, node] : tree_in) {
    ASSERT_EQ(tree_back.count(path), 1u) << "node at depth " << path.size() << " lost";
    EXPECT_TRUE(tree_back.at(path) == node) << "node at depth " << path.size() << " changed";
  }
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
