#include "vslam/detect/darknet_weights.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>

#include "vslam/core/error.hpp"

namespace vslam {
namespace {

// Bounds far above any real network (yolov4 has 1024 filters, kernels of 1-7)
// that keep the parameter arithmetic inside int64: a cfg beyond them is an
// error, not an overflow (found by the darknet_cfg fuzz target).
constexpr int kMaxChannels = 1 << 16;
constexpr int kMaxKernelSize = 1 << 10;
constexpr std::int64_t kMaxParameters = std::int64_t{1} << 36;  // 256 GB of float32

std::string trim(const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return "";
  const auto last = text.find_last_not_of(" \t\r\n");
  return text.substr(first, last - first + 1);
}

// One [section] of a cfg with its key=value options.
struct CfgSection {
  std::string name;
  int line = 0;
  std::map<std::string, std::pair<std::string, int>> options;  // key -> (value, line)
};

std::vector<CfgSection> readSections(std::istream& in, const std::string& cfg_path) {
  std::vector<CfgSection> sections;
  std::string raw;
  int line_number = 0;
  while (std::getline(in, raw)) {
    ++line_number;
    const std::string line = trim(raw);
    if (line.empty() || line[0] == '#' || line[0] == ';') continue;
    if (line[0] == '[') {
      if (line.back() != ']') throw InputError(cfg_path, line_number, "section header without ']'");
      sections.push_back({trim(line.substr(1, line.size() - 2)), line_number, {}});
      continue;
    }
    const auto eq = line.find('=');
    if (eq == std::string::npos) throw InputError(cfg_path, line_number, "expected 'key=value', got '" + line + "'");
    if (sections.empty()) throw InputError(cfg_path, line_number, "option before the first [section]");
    sections.back().options[trim(line.substr(0, eq))] = {trim(line.substr(eq + 1)), line_number};
  }
  if (sections.empty() || (sections.front().name != "net" && sections.front().name != "network"))
    throw InputError(cfg_path, sections.empty() ? 0 : sections.front().line, "a Darknet cfg must start with [net]");
  return sections;
}

// Typed access to one section's options, naming file and line on bad values.
class SectionReader {
 public:
  SectionReader(const std::string& cfg_path, const CfgSection& section) : path_(cfg_path), section_(section) {}

  int integer(const std::string& key, int fallback) const {
    const auto it = section_.options.find(key);
    if (it == section_.options.end()) return fallback;
    return parseInt(it->second.first, it->second.second, key);
  }
  std::vector<int> integers(const std::string& key) const {
    const auto it = section_.options.find(key);
    if (it == section_.options.end())
      throw InputError(path_, section_.line, "[" + section_.name + "] needs '" + key + "'");
    std::vector<int> values;
    std::stringstream list(it->second.first);
    std::string item;
    while (std::getline(list, item, ',')) values.push_back(parseInt(trim(item), it->second.second, key));
    return values;
  }
  bool has(const std::string& key) const { return section_.options.count(key) > 0; }
  std::string text(const std::string& key) const {
    const auto it = section_.options.find(key);
    return it == section_.options.end() ? "" : it->second.first;
  }
  [[noreturn]] void fail(const std::string& what) const { throw InputError(path_, section_.line, what); }

 private:
  int parseInt(const std::string& value, int line, const std::string& key) const {
    try {
      size_t used = 0;
      const int parsed = std::stoi(value, &used);
      if (used == value.size()) return parsed;
    } catch (const std::exception&) {
    }
    throw InputError(path_, line, "'" + key + "' must be an integer, got '" + value + "'");
  }

  const std::string& path_;
  const CfgSection& section_;
};

// Index of the layer a route/shortcut refers to: negative is relative to the
// current layer, non-negative is absolute (Darknet's convention).
int referencedLayer(const SectionReader& reader, int reference, int current) {
  const int index = reference < 0 ? current + reference : reference;
  if (index < 0 || index >= current)
    reader.fail("layer reference " + std::to_string(reference) + " points outside layers 0.." +
                std::to_string(current - 1));
  return index;
}

}  // namespace

std::int64_t DarknetNetwork::parameterCount() const {
  std::int64_t total = 0;
  for (const auto& layer : layers) total += layer.parameters;
  return total;
}

int DarknetNetwork::yoloLayerCount() const {
  return static_cast<int>(std::count_if(layers.begin(), layers.end(),
                                        [](const DarknetLayer& layer) { return layer.type == "yolo"; }));
}

DarknetNetwork parseDarknetCfg(const std::string& cfg_path) {
  std::ifstream in(cfg_path);
  if (!in) throw InputError(cfg_path, 0, "cannot open Darknet cfg file");
  return parseDarknetCfg(in, cfg_path);
}

DarknetNetwork parseDarknetCfg(std::istream& in, const std::string& cfg_path) {
  const std::vector<CfgSection> sections = readSections(in, cfg_path);
  DarknetNetwork network;
  network.cfg_path = cfg_path;
  {
    const SectionReader net(cfg_path, sections.front());
    network.width = net.integer("width", 0);
    network.height = net.integer("height", 0);
    network.channels = net.integer("channels", 3);
    if (network.channels <= 0 || network.channels > kMaxChannels)
      net.fail("[net] channels must be in 1.." + std::to_string(kMaxChannels));
  }

  for (size_t s = 1; s < sections.size(); ++s) {
    const CfgSection& section = sections[s];
    const SectionReader reader(cfg_path, section);
    const int index = static_cast<int>(network.layers.size());
    const int in_channels = index == 0 ? network.channels : network.layers.back().out_channels;
    DarknetLayer layer;
    layer.type = section.name;
    layer.cfg_line = section.line;

    if (section.name == "convolutional" || section.name == "conv") {
      layer.type = "convolutional";
      layer.filters = reader.integer("filters", 1);
      const int size = reader.integer("size", 1);
      const int groups = reader.integer("groups", 1);
      layer.batch_normalize = reader.integer("batch_normalize", 0) != 0;
      if (layer.filters <= 0 || size <= 0 || groups <= 0) reader.fail("filters, size and groups must be positive");
      if (layer.filters > kMaxChannels || size > kMaxKernelSize)
        reader.fail("filters must be at most " + std::to_string(kMaxChannels) + " and size at most " +
                    std::to_string(kMaxKernelSize));
      if (in_channels % groups != 0)
        reader.fail(std::to_string(in_channels) + " input channels do not split into " + std::to_string(groups) +
                    " groups");
      // Darknet's load_convolutional_weights: biases, then (with batch norm)
      // scales, rolling mean, rolling variance, then the kernels.
      const std::int64_t kernels =
          static_cast<std::int64_t>(layer.filters) * (in_channels / groups) * size * size;
      layer.parameters = layer.filters + (layer.batch_normalize ? 3 * layer.filters : 0) + kernels;
      layer.out_channels = layer.filters;
    } else if (section.name == "route") {
      const std::vector<int> references = reader.integers("layers");
      const int groups = reader.integer("groups", 1);
      const int group_id = reader.integer("group_id", 0);
      if (groups <= 0 || group_id < 0 || group_id >= groups) reader.fail("route needs 0 <= group_id < groups");
      int channels = 0;
      for (int reference : references) {
        channels += network.layers[referencedLayer(reader, reference, index)].out_channels;
        if (channels > kMaxChannels) reader.fail("route gives more than " + std::to_string(kMaxChannels) + " channels");
      }
      if (channels % groups != 0)
        reader.fail(std::to_string(channels) + " routed channels do not split into " + std::to_string(groups) +
                    " groups");
      layer.out_channels = channels / groups;
    } else if (section.name == "shortcut") {
      referencedLayer(reader, reader.integer("from", -1), index);
      const std::string weights_type = reader.text("weights_type");
      if (!weights_type.empty() && weights_type != "none")
        reader.fail("shortcut weights_type=" + weights_type + " is not supported");
      layer.out_channels = in_channels;  // Darknet keeps the previous layer's shape
    } else if (section.name == "maxpool" || section.name == "max" || section.name == "avgpool" ||
               section.name == "avg" || section.name == "upsample" || section.name == "dropout") {
      if (index == 0 && section.name != "maxpool") reader.fail("[" + section.name + "] cannot be the first layer");
      layer.out_channels = in_channels;
    } else if (section.name == "yolo") {
      const int classes = reader.integer("classes", 20);
      if (classes <= 0) reader.fail("[yolo] classes must be positive");
      if (network.classes != 0 && network.classes != classes)
        reader.fail("[yolo] layers disagree on the number of classes");
      network.classes = classes;
      layer.out_channels = in_channels;
    } else {
      reader.fail("unsupported section [" + section.name + "]");
    }
    network.layers.push_back(layer);
    if (network.parameterCount() > kMaxParameters)
      reader.fail("the network needs more than " + std::to_string(kMaxParameters) + " parameters up to this layer");
  }
  return network;
}

int DarknetWeightsHeader::bytes() const {
  // Darknet writes `seen` as size_t from version 0.2 on.
  // Darknet's own test, in 64 bits: a corrupt header's version must not overflow.
  const bool wide_seen = (std::int64_t{major} * 10 + minor) >= 2 && major < 1000 && minor < 1000;
  return 3 * 4 + (wide_seen ? 8 : 4);
}

DarknetWeightsHeader readDarknetWeightsHeader(const std::string& weights_path) {
  std::ifstream in(weights_path, std::ios::binary);
  if (!in) throw InputError(weights_path, 0, "cannot open Darknet weights file");
  return readDarknetWeightsHeader(in, weights_path);
}

DarknetWeightsHeader readDarknetWeightsHeader(std::istream& in, const std::string& weights_path) {
  DarknetWeightsHeader header;
  std::int32_t version[3];
  if (!in.read(reinterpret_cast<char*>(version), sizeof(version)))
    throw InputError(weights_path, 0, "too short for a Darknet weights header");
  header.major = version[0];
  header.minor = version[1];
  header.revision = version[2];
  auto readSeen = [&](auto seen) {  // int64 or int32, by the version
    if (in.read(reinterpret_cast<char*>(&seen), sizeof(seen))) header.seen = seen;
  };
  if (header.bytes() == 20)
    readSeen(std::int64_t{0});
  else
    readSeen(std::int32_t{0});
  return header;
}

std::int64_t expectedWeightsBytes(const DarknetNetwork& network, const DarknetWeightsHeader& header) {
  return header.bytes() + 4 * network.parameterCount();
}

DarknetWeightsHeader checkWeightsFile(const std::string& cfg_path, const std::string& weights_path) {
  return checkWeightsFile(parseDarknetCfg(cfg_path), weights_path);
}

DarknetWeightsHeader checkWeightsFile(const DarknetNetwork& network, const std::string& weights_path) {
  const DarknetWeightsHeader header = readDarknetWeightsHeader(weights_path);
  std::error_code error;
  const auto actual = static_cast<std::int64_t>(std::filesystem::file_size(weights_path, error));
  if (error) throw InputError(weights_path, 0, "cannot read the size of the weights file: " + error.message());
  checkWeightsSize(network, header, actual, weights_path);
  return header;
}

void checkWeightsSize(const DarknetNetwork& network, const DarknetWeightsHeader& header, std::int64_t actual,
                      const std::string& weights_path) {
  const std::int64_t expected = expectedWeightsBytes(network, header);
  if (actual != expected)
    throw InputError(weights_path, 0,
                     "weights file has " + std::to_string(actual) + " bytes but " + network.cfg_path + " needs " +
                         std::to_string(expected) + " bytes (" + std::to_string(header.bytes()) + "-byte header + " +
                         std::to_string(network.parameterCount()) + " float32 parameters); " +
                         (actual < expected ? "the file is truncated (an interrupted download?)"
                                            : "the weights do not belong to this cfg"));
}

void writePlaceholderWeights(const std::string& cfg_path, const std::string& weights_path, unsigned seed) {
  const DarknetNetwork network = parseDarknetCfg(cfg_path);
  std::ofstream out(weights_path, std::ios::binary | std::ios::trunc);
  if (!out) throw InputError(weights_path, 0, "cannot write placeholder weights");
  const std::int32_t version[3] = {0, 2, 5};
  const std::int64_t seen = 0;
  out.write(reinterpret_cast<const char*>(version), sizeof(version));
  out.write(reinterpret_cast<const char*>(&seen), sizeof(seen));

  std::mt19937 random(seed);
  std::uniform_real_distribution<float> small(-0.01f, 0.01f);
  auto write = [&](std::int64_t count, float fixed, bool random_values) {
    std::vector<float> values(static_cast<size_t>(count));
    for (float& v : values) v = random_values ? small(random) : fixed;
    out.write(reinterpret_cast<const char*>(values.data()), static_cast<std::streamsize>(values.size() * 4));
  };
  for (const DarknetLayer& layer : network.layers) {
    if (layer.type != "convolutional") continue;
    std::int64_t remaining = layer.parameters;
    write(layer.filters, 0.f, true);  // biases
    remaining -= layer.filters;
    if (layer.batch_normalize) {
      // Unit variance and scale keep batch norm finite: it divides by sqrt(variance).
      write(layer.filters, 1.f, false);  // scales
      write(layer.filters, 0.f, false);  // rolling mean
      write(layer.filters, 1.f, false);  // rolling variance
      remaining -= 3 * layer.filters;
    }
    write(remaining, 0.f, true);  // kernels
  }
  if (!out) throw InputError(weights_path, 0, "failed writing placeholder weights");
}

}  // namespace vslam
