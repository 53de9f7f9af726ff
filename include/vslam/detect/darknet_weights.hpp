#pragma once
// Darknet network definitions (.cfg) and the size of their .weights files.
//
// OpenCV's Darknet importer reads whatever bytes a .weights file has and fills
// the rest with nothing: a truncated download loads without a word and then
// detects nothing. The expected size follows from the cfg alone (every
// convolution's parameter count plus the file header), so we check it first.
#include <cstdint>
#include <istream>
#include <string>
#include <vector>

namespace vslam {

// One layer of a parsed cfg, in file order (the [net] section is not a layer).
struct DarknetLayer {
  std::string type;              // "convolutional", "route", "yolo", ...
  int cfg_line = 0;              // line of its [section] header
  int out_channels = 0;          // channels of its output
  std::int64_t parameters = 0;   // float32 values it reads from the weights file
  int filters = 0;               // convolutions only
  bool batch_normalize = false;  // convolutions only
};

struct DarknetNetwork {
  std::string cfg_path;
  int width = 0, height = 0, channels = 3;  // from [net]
  int classes = 0;                          // from the [yolo] layers (0 when there are none)
  std::vector<DarknetLayer> layers;

  std::int64_t parameterCount() const;
  int yoloLayerCount() const;
};

// Parses the sections yolov3/v4(-tiny) and Yolo-Fastest use: [net],
// [convolutional], [maxpool], [avgpool], [route] (with groups/group_id),
// [shortcut], [upsample], [dropout], [yolo]. Throws InputError naming the
// cfg file and line for an unreadable file, an unknown section, a bad value
// or a layer reference that points nowhere.
DarknetNetwork parseDarknetCfg(const std::string& cfg_path);
// The same from a stream; `cfg_path` is the file named in errors.
DarknetNetwork parseDarknetCfg(std::istream& in, const std::string& cfg_path);

// The first bytes of a .weights file: version, then the number of images
// seen in training (int64 from version 0.2 on, int32 before).
struct DarknetWeightsHeader {
  std::int32_t major = 0, minor = 2, revision = 0;
  // Images seen in training: 0 in placeholder weights (writePlaceholderWeights);
  // -1 when the file ends before the field.
  std::int64_t seen = -1;
  int bytes() const;  // 20 or 16
};

// Throws InputError naming the file when it cannot be read or is shorter than a header.
DarknetWeightsHeader readDarknetWeightsHeader(const std::string& weights_path);
DarknetWeightsHeader readDarknetWeightsHeader(std::istream& in, const std::string& weights_path);

// Header plus 4 bytes per parameter.
std::int64_t expectedWeightsBytes(const DarknetNetwork& network, const DarknetWeightsHeader& header);

// Throws InputError naming the weights file, its size and the size the cfg
// implies when they differ (or when the file is missing). Returns the header
// it read, so that a caller need not read it again.
DarknetWeightsHeader checkWeightsFile(const std::string& cfg_path, const std::string& weights_path);
// The same against a cfg already parsed (a caller that needs the network anyway).
DarknetWeightsHeader checkWeightsFile(const DarknetNetwork& network, const std::string& weights_path);
// The comparison itself, for a weights file of `actual_bytes` bytes.
void checkWeightsSize(const DarknetNetwork& network, const DarknetWeightsHeader& header, std::int64_t actual_bytes,
                      const std::string& weights_path);

// Writes a weights file of exactly the expected size for `cfg_path` (version
// 0.2.5 header, small random parameters from `seed`): lets tests and benchmarks
// run a network whose trained weights are not available.
void writePlaceholderWeights(const std::string& cfg_path, const std::string& weights_path, unsigned seed = 1);

}  // namespace vslam
