#include "vslam/io/sequence_files.hpp"

#include <cstdio>
#include <filesystem>

#include "vslam/core/error.hpp"

namespace vslam {
namespace {

std::string timestampText(double t) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.6f", t);
  return text;
}

}  // namespace

std::vector<ListedImage> parseTumImageList(const std::vector<TextRow>& rows, const std::string& file,
                                           const std::string& root) {
  namespace fs = std::filesystem;
  std::vector<ListedImage> images;
  for (const TextRow& row : rows) {
    if (row.fields.size() != 2)
      throw InputError(file, row.line,
                       "expected 'timestamp path', found " + std::to_string(row.fields.size()) + " fields");
    ListedImage image;
    image.timestamp = parseNumber(row.fields[0], file, row.line, "timestamp");
    image.path = (fs::path(root) / row.fields[1]).lexically_normal().string();
    image.line = row.line;
    if (!images.empty() && image.timestamp <= images.back().timestamp)
      throw InputError(file, row.line,
                       "timestamp " + timestampText(image.timestamp) + " goes backwards (previous line has " +
                           timestampText(images.back().timestamp) + ")");
    images.push_back(image);
  }
  if (images.empty()) throw InputError(file, 0, "lists no images");
  return images;
}

std::vector<double> parseKittiTimes(const std::vector<TextRow>& rows, const std::string& file) {
  std::vector<double> times;
  for (const TextRow& row : rows) {
    if (row.fields.size() != 1)
      throw InputError(file, row.line,
                       "expected one timestamp, found " + std::to_string(row.fields.size()) + " fields");
    const double t = parseNumber(row.fields[0], file, row.line, "timestamp");
    if (!times.empty() && t <= times.back())
      throw InputError(file, row.line,
                       "timestamp " + timestampText(t) + " goes backwards (previous line has " +
                           timestampText(times.back()) + ")");
    times.push_back(t);
  }
  if (times.empty()) throw InputError(file, 0, "lists no timestamps");
  return times;
}

void parseKittiCalibration(const std::vector<TextRow>& rows, const std::string& file, PinholeCamera& camera) {
  auto projection = [&](const TextRow& row) {
    if (row.fields.size() != 13)
      throw InputError(file, row.line,
                       "expected '" + row.fields[0] + "' and 12 numbers, found " +
                           std::to_string(row.fields.size() - 1) + " numbers");
    std::vector<double> p;
    for (int k = 1; k < 13; ++k) p.push_back(parseNumber(row.fields[k], file, row.line, row.fields[0] + " entry"));
    return p;
  };
  bool found_p0 = false;
  for (const TextRow& row : rows) {
    if (row.fields[0] == "P0:") {
      const std::vector<double> p = projection(row);
      if (p[0] <= 0 || p[5] <= 0) throw InputError(file, row.line, "P0 has a non-positive focal length");
      camera.fx = p[0];
      camera.cx = p[2];
      camera.fy = p[5];
      camera.cy = p[6];
      found_p0 = true;
    } else if (row.fields[0] == "P1:") {
      // P1 = K [I | -b e_x]: its fourth entry is -fx * baseline, i.e. -bf.
      const std::vector<double> p = projection(row);
      if (p[0] > 0) camera.bf = -p[3];
    }
  }
  if (!found_p0) throw InputError(file, 0, "no 'P0:' line (the left camera's 3x4 projection matrix)");
}

}  // namespace vslam
