// Vocabulary files: our compact binary form and DBoW2's text format.
//
// Binary layout, version 1 (all integers little-endian, whatever the host):
//   char[8]  "VSLAMVOC"
//   u32      version (1)
//   u32      branching, depth, seed, max_kmeans_iterations
//   u32      node_count, word_count
//   u16      child_count[node_count]      nodes in breadth-first order; node 0 is the root
//   u8       descriptor[node_count - 1][32]  nodes 1 .. node_count - 1
//   f64      idf[word_count]              IEEE-754 binary64; words = leaves in node order
// The tree shape follows from the child counts alone: the children of node n
// are the child_count[n] nodes after those of node n - 1.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "vslam/core/error.hpp"
#include "vslam/place/vocabulary.hpp"

namespace vslam {
namespace {

constexpr char kMagic[8] = {'V', 'S', 'L', 'A', 'M', 'V', 'O', 'C'};
constexpr uint32_t kBinaryVersion = 1;
constexpr size_t kDescriptorBytes = 32;
constexpr size_t kHeaderBytes = sizeof(kMagic) + 7 * sizeof(uint32_t);

void appendLittleEndian(std::string& out, uint64_t value, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<char>((value >> (8 * i)) & 0xFF));
}

uint64_t readLittleEndian(const std::string& in, size_t offset, int bytes) {
  uint64_t value = 0;
  for (int i = 0; i < bytes; ++i)
    value |= static_cast<uint64_t>(static_cast<unsigned char>(in[offset + i])) << (8 * i);
  return value;
}

void writeFile(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw InputError(path, 0, "cannot open for writing");
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) throw InputError(path, 0, "write failed");
}

std::string readFile(const std::string& path) {
  if (std::filesystem::is_directory(path)) throw InputError(path, 0, "is a directory, not a vocabulary file");
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw InputError(path, 0, "cannot open vocabulary file");
  // Read straight into the string: ORBvoc.txt is about 145 MB.
  std::string bytes(static_cast<size_t>(in.tellg()), '\0');
  in.seekg(0);
  in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!in) throw InputError(path, 0, "read failed");
  return bytes;
}

// Whitespace-separated fields of one line.
std::vector<std::string_view> splitFields(std::string_view line) {
  std::vector<std::string_view> fields;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    const size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > start) fields.push_back(line.substr(start, i - start));
  }
  return fields;
}

bool parseInteger(std::string_view field, long long& value) {
  const auto [end, error] = std::from_chars(field.data(), field.data() + field.size(), value);
  return error == std::errc() && end == field.data() + field.size();
}

bool parseReal(std::string_view field, double& value) {
  const auto [end, error] = std::from_chars(field.data(), field.data() + field.size(), value);
  return error == std::errc() && end == field.data() + field.size() && std::isfinite(value);
}

}  // namespace

// ---------------------------------------------------------------- binary

void Vocabulary::save(const std::string& path) const {
  if (empty()) throw std::logic_error("Vocabulary::save: the vocabulary is empty");
  std::string bytes;
  bytes.reserve(kHeaderBytes + nodeCount() * (2 + kDescriptorBytes) + wordCount() * 8);
  bytes.append(kMagic, sizeof(kMagic));
  for (uint32_t value : {kBinaryVersion, static_cast<uint32_t>(branching_), static_cast<uint32_t>(depth_), seed_,
                         static_cast<uint32_t>(max_kmeans_iterations_), static_cast<uint32_t>(nodeCount()),
                         static_cast<uint32_t>(wordCount())})
    appendLittleEndian(bytes, value, 4);
  for (uint32_t count : child_count_) appendLittleEndian(bytes, count, 2);
  for (size_t node = 1; node < nodeCount(); ++node) {
    char descriptor[kDescriptorBytes];
    std::memcpy(descriptor, &node_descriptors_[node * kWordsPerDescriptor], kDescriptorBytes);
    bytes.append(descriptor, kDescriptorBytes);
  }
  for (double weight : weights_) {
    uint64_t bits;
    std::memcpy(&bits, &weight, sizeof(bits));
    appendLittleEndian(bytes, bits, 8);
  }
  writeFile(path, bytes);
}

namespace {

// Checks that child counts describe a breadth-first tree no deeper than
// `depth` with at most `branching` children per node; returns "" or the problem.
std::string treeProblem(const std::vector<uint32_t>& child_count, int branching, int depth) {
  uint64_t next = 1;
  std::vector<int> level(child_count.size(), 0);
  for (size_t n = 0; n < child_count.size(); ++n) {
    if (child_count[n] > static_cast<uint32_t>(branching))
      return "node " + std::to_string(n) + " has " + std::to_string(child_count[n]) + " children, more than the branching factor " +
             std::to_string(branching);
    if (child_count[n] > 0 && next <= n) return "child counts do not describe a tree (node " + std::to_string(n) + ")";
    for (uint64_t c = next; c < next + child_count[n] && c < child_count.size(); ++c) {
      level[c] = level[n] + 1;
      if (level[c] > depth)
        return "node " + std::to_string(c) + " is at level " + std::to_string(level[c]) + ", deeper than the depth " +
               std::to_string(depth);
    }
    next += child_count[n];
  }
  if (next != child_count.size())
    return "child counts add up to " + std::to_string(next - 1) + " children for " + std::to_string(child_count.size()) +
           " nodes (expected " + std::to_string(child_count.size() - 1) + ")";
  return "";
}

}  // namespace

Vocabulary Vocabulary::load(const std::string& path) { return parse(readFile(path), path); }

Vocabulary Vocabulary::parse(const std::string& bytes, const std::string& name) {
  if (bytes.size() >= sizeof(kMagic) && std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) == 0)
    return loadBinary(name, bytes);
  return loadDbow2Text(name, bytes);
}

Vocabulary Vocabulary::loadBinary(const std::string& path, const std::string& bytes) {
  const auto fail = [&](size_t offset, const std::string& what) {
    return InputError(path, 0, "byte " + std::to_string(offset) + ": " + what);
  };
  if (bytes.size() < kHeaderBytes) throw fail(bytes.size(), "truncated header");
  size_t offset = sizeof(kMagic);
  const auto u32 = [&]() {
    const uint32_t value = static_cast<uint32_t>(readLittleEndian(bytes, offset, 4));
    offset += 4;
    return value;
  };
  const uint32_t version = u32();
  if (version != kBinaryVersion)
    throw fail(8, "version " + std::to_string(version) + " is not supported (this build reads version " +
                      std::to_string(kBinaryVersion) + ")");
  const uint32_t branching = u32();
  const uint32_t depth = u32();
  const uint32_t seed = u32();
  const uint32_t iterations = u32();
  const uint32_t node_count = u32();
  const uint32_t word_count = u32();
  if (branching < 2 || branching > 65535) throw fail(12, "branching " + std::to_string(branching) + " is not in [2, 65535]");
  if (depth < 1 || depth > 32) throw fail(16, "depth " + std::to_string(depth) + " is not in [1, 32]");
  if (iterations > 1000000) throw fail(24, "max_kmeans_iterations " + std::to_string(iterations) + " is implausible");
  if (node_count < 1) throw fail(28, "no nodes");
  const uint64_t expected_size = kHeaderBytes + uint64_t{node_count} * 2 +
                                 (uint64_t{node_count} - 1) * kDescriptorBytes + uint64_t{word_count} * 8;
  if (bytes.size() != expected_size)
    throw fail(std::min<uint64_t>(bytes.size(), expected_size),
               std::string(bytes.size() < expected_size ? "truncated: " : "unexpected data after the end: ") +
                   std::to_string(node_count) + " nodes and " + std::to_string(word_count) + " words take " +
                   std::to_string(expected_size) + " bytes, the file has " + std::to_string(bytes.size()));

  Vocabulary vocabulary;
  vocabulary.branching_ = static_cast<int>(branching);
  vocabulary.depth_ = static_cast<int>(depth);
  vocabulary.seed_ = seed;
  vocabulary.max_kmeans_iterations_ = static_cast<int>(iterations);
  const size_t tree_offset = offset;
  vocabulary.child_count_.resize(node_count);
  for (uint32_t n = 0; n < node_count; ++n, offset += 2)
    vocabulary.child_count_[n] = static_cast<uint32_t>(readLittleEndian(bytes, offset, 2));
  const std::string problem = treeProblem(vocabulary.child_count_, vocabulary.branching_, vocabulary.depth_);
  if (!problem.empty()) throw fail(tree_offset, problem);
  vocabulary.node_descriptors_.assign(size_t{node_count} * kWordsPerDescriptor, 0);
  for (uint32_t n = 1; n < node_count; ++n, offset += kDescriptorBytes)
    std::memcpy(&vocabulary.node_descriptors_[size_t{n} * kWordsPerDescriptor], bytes.data() + offset,
                kDescriptorBytes);
  vocabulary.indexTree();
  if (vocabulary.wordCount() != word_count)
    throw fail(32, "the header says " + std::to_string(word_count) + " words but the tree has " +
                       std::to_string(vocabulary.wordCount()) + " leaves");
  vocabulary.weights_.resize(word_count);
  for (uint32_t w = 0; w < word_count; ++w, offset += 8) {
    const uint64_t bits = readLittleEndian(bytes, offset, 8);
    double weight;
    std::memcpy(&weight, &bits, sizeof(weight));
    if (!std::isfinite(weight) || weight < 0)
      throw fail(offset, "weight of word " + std::to_string(w) + " is not a finite number >= 0");
    vocabulary.weights_[w] = weight;
  }
  return vocabulary;
}

// ---------------------------------------------------------------- DBoW2 text

void Vocabulary::saveDbow2Text(const std::string& path) const {
  if (empty()) throw std::logic_error("Vocabulary::saveDbow2Text: the vocabulary is empty");
  std::vector<NodeId> parent(nodeCount(), 0);
  for (NodeId n = 0; n < nodeCount(); ++n)
    for (uint32_t c = 0; c < child_count_[n]; ++c) parent[first_child_[n] + c] = n;

  std::string text = std::to_string(branching_) + " " + std::to_string(depth_) + " 0 0\n";  // L1 scoring, TF-IDF
  char number[64];
  for (NodeId n = 1; n < nodeCount(); ++n) {
    const bool leaf = child_count_[n] == 0;
    text += std::to_string(parent[n]);
    text += leaf ? " 1" : " 0";
    uint8_t descriptor[kDescriptorBytes];
    std::memcpy(descriptor, &node_descriptors_[size_t{n} * kWordsPerDescriptor], kDescriptorBytes);
    for (uint8_t byte : descriptor) {
      text += ' ';
      text += std::to_string(byte);
    }
    // Shortest form that reads back to the same double.
    const double weight = leaf ? weights_[word_of_node_[n]] : 0.0;
    const auto result = std::to_chars(number, number + sizeof(number), weight);
    text += ' ';
    text.append(number, result.ptr);
    text += '\n';
  }
  writeFile(path, text);
}

Vocabulary Vocabulary::loadDbow2Text(const std::string& path, const std::string& text) {
  const std::string_view all(text);
  size_t position = 0;
  int line_number = 0;
  std::string_view line;
  const auto nextLine = [&]() {
    if (position >= all.size()) return false;
    size_t end = all.find('\n', position);
    if (end == std::string_view::npos) end = all.size();
    line = all.substr(position, end - position);
    position = end + 1;
    ++line_number;
    return true;
  };
  const auto fail = [&](const std::string& what) { return InputError(path, line_number, what); };
  const auto quoted = [](std::string_view field) { return "'" + std::string(field.substr(0, 20)) + "'"; };

  // Header: "k L scoring weighting".
  const std::string not_a_vocabulary =
      "not a vocabulary: expected vslam's binary form (starting with VSLAMVOC) or DBoW2 text "
      "(first line 'k L scoring weighting')";
  if (!nextLine()) throw InputError(path, 1, "empty file; " + not_a_vocabulary);
  const std::vector<std::string_view> header = splitFields(line);
  long long k = 0, levels = 0, scoring = 0, weighting = 0;
  if (header.size() != 4 || !parseInteger(header[0], k) || !parseInteger(header[1], levels) ||
      !parseInteger(header[2], scoring) || !parseInteger(header[3], weighting))
    throw fail(not_a_vocabulary);
  if (k < 2 || k > 65535) throw fail("branching factor k = " + std::to_string(k) + " is not in [2, 65535]");
  if (levels < 1 || levels > 32) throw fail("depth L = " + std::to_string(levels) + " is not in [1, 32]");
  if (scoring != 0)
    throw fail("scoring " + std::to_string(scoring) + " is not supported: vslam scores with L1 (DBoW2's 0)");
  if (weighting != 0)
    throw fail("weighting " + std::to_string(weighting) + " is not supported: vslam weights with TF-IDF (DBoW2's 0)");

  // Nodes in file order; node 0 is the root, which has no line.
  constexpr size_t kFields = 2 + kDescriptorBytes + 1;
  std::vector<uint32_t> parent{0};
  std::vector<uint8_t> is_leaf{0};
  std::vector<int> level{0};
  std::vector<int> line_of{1};
  std::vector<uint32_t> child_count{0};
  std::vector<uint8_t> descriptors(kDescriptorBytes, 0);
  std::vector<double> weight{0.0};
  while (nextLine()) {
    const std::vector<std::string_view> fields = splitFields(line);
    if (fields.empty()) continue;
    if (fields.size() != kFields)
      throw fail("expected " + std::to_string(kFields) + " numbers (parent, is_leaf, " +
                 std::to_string(kDescriptorBytes) + " descriptor bytes, weight), found " + std::to_string(fields.size()));
    const size_t node = parent.size();
    long long parent_id = 0, leaf = 0;
    if (!parseInteger(fields[0], parent_id) || parent_id < 0 || static_cast<size_t>(parent_id) >= node)
      throw fail("parent " + quoted(fields[0]) + " is not the id of an earlier node (0 .. " + std::to_string(node - 1) +
                 "; node " + std::to_string(node) + " is on this line)");
    if (is_leaf[parent_id])
      throw fail("parent " + std::to_string(parent_id) + " is a leaf (line " + std::to_string(line_of[parent_id]) + ")");
    if (child_count[parent_id] >= static_cast<uint32_t>(k))
      throw fail("node " + std::to_string(parent_id) + " gets more than k = " + std::to_string(k) + " children");
    if (level[parent_id] + 1 > levels)
      throw fail("node " + std::to_string(node) + " is at level " + std::to_string(level[parent_id] + 1) +
                 ", deeper than L = " + std::to_string(levels));
    if (!parseInteger(fields[1], leaf) || (leaf != 0 && leaf != 1))
      throw fail("is_leaf " + quoted(fields[1]) + " is not 0 or 1");
    for (size_t b = 0; b < kDescriptorBytes; ++b) {
      long long byte = 0;
      if (!parseInteger(fields[2 + b], byte) || byte < 0 || byte > 255)
        throw fail("descriptor byte " + std::to_string(b) + " " + quoted(fields[2 + b]) + " is not an integer in [0, 255]");
      descriptors.push_back(static_cast<uint8_t>(byte));
    }
    double node_weight = 0.0;
    if (!parseReal(fields[kFields - 1], node_weight) || node_weight < 0)
      throw fail("weight " + quoted(fields[kFields - 1]) + " is not a finite number >= 0");
    parent.push_back(static_cast<uint32_t>(parent_id));
    is_leaf.push_back(static_cast<uint8_t>(leaf));
    level.push_back(level[parent_id] + 1);
    line_of.push_back(line_number);
    child_count.push_back(0);
    ++child_count[parent_id];
    weight.push_back(node_weight);
  }
  const size_t node_count = parent.size();
  if (node_count == 1) throw InputError(path, line_number + 1, "no node lines after the header");
  for (size_t n = 1; n < node_count; ++n)
    if (!is_leaf[n] && child_count[n] == 0)
      throw InputError(path, line_of[n],
                       "node " + std::to_string(n) + " is not a leaf (is_leaf 0) but no line names it as parent");

  // Renumber breadth-first, keeping each node's children in file order (which
  // keeps DBoW2's tie-break: the first closest child wins).
  std::vector<uint32_t> children_begin(node_count + 1, 0);
  for (size_t n = 0; n < node_count; ++n) children_begin[n + 1] = children_begin[n] + child_count[n];
  std::vector<uint32_t> children(node_count - 1);
  {
    std::vector<uint32_t> filled(children_begin.begin(), children_begin.end() - 1);
    for (size_t n = 1; n < node_count; ++n) children[filled[parent[n]]++] = static_cast<uint32_t>(n);
  }
  std::vector<uint32_t> breadth_first{0};
  breadth_first.reserve(node_count);
  for (size_t i = 0; i < breadth_first.size(); ++i) {
    const uint32_t n = breadth_first[i];
    breadth_first.insert(breadth_first.end(), children.begin() + children_begin[n], children.begin() + children_begin[n + 1]);
  }

  Vocabulary vocabulary;
  vocabulary.branching_ = static_cast<int>(k);
  vocabulary.depth_ = static_cast<int>(levels);
  vocabulary.child_count_.resize(node_count);
  vocabulary.node_descriptors_.assign(node_count * kWordsPerDescriptor, 0);
  for (size_t id = 0; id < node_count; ++id) {
    const uint32_t file_node = breadth_first[id];
    vocabulary.child_count_[id] = child_count[file_node];
    std::memcpy(&vocabulary.node_descriptors_[id * kWordsPerDescriptor], &descriptors[file_node * kDescriptorBytes],
                kDescriptorBytes);
  }
  vocabulary.indexTree();
  vocabulary.weights_.resize(vocabulary.wordCount());
  for (WordId w = 0; w < vocabulary.wordCount(); ++w) vocabulary.weights_[w] = weight[breadth_first[vocabulary.node_of_word_[w]]];
  return vocabulary;
}

}  // namespace vslam
