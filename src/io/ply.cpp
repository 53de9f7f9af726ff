#include "vslam/io/ply.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "vslam/core/error.hpp"

namespace vslam {
namespace {

bool hostIsLittleEndian() {
  const uint16_t probe = 1;
  unsigned char first_byte;
  std::memcpy(&first_byte, &probe, 1);
  return first_byte == 1;
}

// Appends the bytes of `value` in little-endian order.
template <typename T>
void appendLittleEndian(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if (!hostIsLittleEndian()) std::reverse(bytes, bytes + sizeof(T));
  out.append(bytes, sizeof(T));
}

enum class Format { Ascii, BinaryLittleEndian, BinaryBigEndian };

enum class ScalarType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

struct Property {
  std::string name;
  ScalarType type = ScalarType::Float32;
  bool is_list = false;
  ScalarType count_type = ScalarType::UInt8;  // lists only
};

struct Element {
  std::string name;
  long count = 0;
  std::vector<Property> properties;
};

bool parseScalarType(const std::string& name, ScalarType& type) {
  static constexpr std::pair<const char*, ScalarType> kNames[] = {
      {"char", ScalarType::Int8},     {"int8", ScalarType::Int8},       {"uchar", ScalarType::UInt8},
      {"uint8", ScalarType::UInt8},   {"short", ScalarType::Int16},     {"int16", ScalarType::Int16},
      {"ushort", ScalarType::UInt16}, {"uint16", ScalarType::UInt16},   {"int", ScalarType::Int32},
      {"int32", ScalarType::Int32},   {"uint", ScalarType::UInt32},     {"uint32", ScalarType::UInt32},
      {"float", ScalarType::Float32}, {"float32", ScalarType::Float32}, {"double", ScalarType::Float64},
      {"float64", ScalarType::Float64}};
  for (const auto& [text, value] : kNames)
    if (name == text) {
      type = value;
      return true;
    }
  return false;
}

size_t sizeOf(ScalarType type) {
  switch (type) {
    case ScalarType::Int8: case ScalarType::UInt8: return 1;
    case ScalarType::Int16: case ScalarType::UInt16: return 2;
    case ScalarType::Int32: case ScalarType::UInt32: case ScalarType::Float32: return 4;
    case ScalarType::Float64: return 8;
  }
  return 0;
}

bool isFloating(ScalarType type) { return type == ScalarType::Float32 || type == ScalarType::Float64; }

struct Header {
  Format format = Format::Ascii;
  std::vector<Element> elements;
  int lines = 0;
};

Header readHeader(std::istream& in, const std::string& path) {
  Header header;
  std::string line;
  auto fail = [&](const std::string& what) { throw InputError(path, header.lines, what); };
  auto nextLine = [&]() {
    if (!std::getline(in, line)) fail("unexpected end of file in the PLY header (no end_header)");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    ++header.lines;
  };
  nextLine();
  if (line != "ply") fail("not a PLY file (first line is not \"ply\")");
  bool have_format = false;
  for (;;) {
    nextLine();
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "end_header") break;
    if (keyword.empty() || keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "format") {
      std::string name, version;
      words >> name >> version;
      if (name == "ascii") header.format = Format::Ascii;
      else if (name == "binary_little_endian") header.format = Format::BinaryLittleEndian;
      else if (name == "binary_big_endian") header.format = Format::BinaryBigEndian;
      else fail("unknown PLY format \"" + name + "\"");
      have_format = true;
    } else if (keyword == "element") {
      Element element;
      if (!(words >> element.name >> element.count) || element.count < 0) fail("malformed element line: " + line);
      header.elements.push_back(element);
    } else if (keyword == "property") {
      if (header.elements.empty()) fail("property before any element");
      Property property;
      std::string type_name;
      words >> type_name;
      if (type_name == "list") {
        std::string count_type, item_type;
        words >> count_type >> item_type >> property.name;
        property.is_list = true;
        if (!parseScalarType(count_type, property.count_type) || !parseScalarType(item_type, property.type))
          fail("unknown list types in: " + line);
      } else {
        words >> property.name;
        if (!parseScalarType(type_name, property.type)) fail("unknown property type \"" + type_name + "\"");
      }
      if (property.name.empty()) fail("property without a name: " + line);
      header.elements.back().properties.push_back(property);
    } else {
      fail("unexpected header line: " + line);
    }
  }
  if (!have_format) fail("no format line in the PLY header");
  return header;
}

// Reads one value of any PLY scalar type as a double.
class ValueReader {
 public:
  ValueReader(std::istream& in, Format format, const std::string& path) : in_(in), format_(format), path_(path) {}

  double read(ScalarType type, const std::string& where) {
    if (format_ == Format::Ascii) {
      double value;
      if (!(in_ >> value)) throw InputError(path_, 0, where + ": missing or non-numeric value");
      return value;
    }
    unsigned char bytes[8];
    const size_t size = sizeOf(type);
    if (!in_.read(reinterpret_cast<char*>(bytes), static_cast<std::streamsize>(size)))
      throw InputError(path_, 0, where + ": unexpected end of file (truncated binary data)");
    const bool file_little = format_ == Format::BinaryLittleEndian;
    if (file_little != hostIsLittleEndian()) std::reverse(bytes, bytes + size);
    switch (type) {
      case ScalarType::Int8: return as<int8_t>(bytes);
      case ScalarType::UInt8: return as<uint8_t>(bytes);
      case ScalarType::Int16: return as<int16_t>(bytes);
      case ScalarType::UInt16: return as<uint16_t>(bytes);
      case ScalarType::Int32: return as<int32_t>(bytes);
      case ScalarType::UInt32: return as<uint32_t>(bytes);
      case ScalarType::Float32: return as<float>(bytes);
      case ScalarType::Float64: return as<double>(bytes);
    }
    return 0.0;
  }

 private:
  template <typename T>
  static double as(const unsigned char* bytes) {
    T value;
    std::memcpy(&value, bytes, sizeof(T));
    return static_cast<double>(value);
  }

  std::istream& in_;
  Format format_;
  std::string path_;
};

// Index of the first property with one of `names`, or -1.
int findProperty(const Element& element, std::initializer_list<const char*> names) {
  for (size_t i = 0; i < element.properties.size(); ++i)
    for (const char* name : names)
      if (element.properties[i].name == name && !element.properties[i].is_list) return static_cast<int>(i);
  return -1;
}

// NaN counts as 0: std::clamp would pass it through to an undefined cast.
unsigned char colourByte(double value, ScalarType type) {
  const double scaled = isFloating(type) ? value * 255.0 : value;
  if (std::isnan(scaled)) return 0;
  return static_cast<unsigned char>(std::clamp(std::round(scaled), 0.0, 255.0));
}

}  // namespace

void writeMapPly(const std::string& path, const std::vector<PlyPoint>& points) {
  std::string data =
      "ply\n"
      "format binary_little_endian 1.0\n"
      "comment vslam map points; class_id is the COCO class index, -1 for none\n"
      "element vertex " + std::to_string(points.size()) + "\n"
      "property float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\n"
      "property int class_id\n"
      "end_header\n";
  data.reserve(data.size() + points.size() * 19);
  for (const PlyPoint& point : points) {
    for (int axis = 0; axis < 3; ++axis) appendLittleEndian(data, static_cast<float>(point.position[axis]));
    data += static_cast<char>(point.bgr[2]);
    data += static_cast<char>(point.bgr[1]);
    data += static_cast<char>(point.bgr[0]);
    appendLittleEndian(data, static_cast<int32_t>(point.class_id));
  }
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error(path + ": cannot open for writing");
  out.write(data.data(), static_cast<std::streamsize>(data.size()));
  out.close();  // a full disk shows only when the buffer is flushed
  if (!out) throw std::runtime_error(path + ": write failed");
}

std::vector<PlyPoint> readMapPly(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open the PLY file");
  return readMapPly(in, path);
}

std::vector<PlyPoint> readMapPly(std::istream& in, const std::string& path) {
  const Header header = readHeader(in, path);
  ValueReader reader(in, header.format, path);

  std::vector<PlyPoint> points;
  bool found_vertices = false;
  for (const Element& element : header.elements) {
    const bool is_vertex = element.name == "vertex";
    if (found_vertices) break;  // nothing after the vertices is needed
    const int x = findProperty(element, {"x"}), y = findProperty(element, {"y"}), z = findProperty(element, {"z"});
    const int red = findProperty(element, {"red", "r", "diffuse_red"});
    const int green = findProperty(element, {"green", "g", "diffuse_green"});
    const int blue = findProperty(element, {"blue", "b", "diffuse_blue"});
    const int class_id = findProperty(element, {"class_id"});
    if (is_vertex && (x < 0 || y < 0 || z < 0))
      throw InputError(path, 0, "the vertex element has no x, y and z properties");

    // An element without properties has no bytes to read, whatever its count
    // (a count of 9e18 took forever; found by the ply fuzz target).
    if (element.properties.empty()) continue;
    std::vector<double> values(element.properties.size(), 0.0);
    // The header's count is not trusted with memory: the data may be shorter.
    if (is_vertex) points.reserve(static_cast<size_t>(std::min<long>(element.count, 1 << 20)));
    for (long index = 0; index < element.count; ++index) {
      const std::string where = element.name + " " + std::to_string(index) + " of " + std::to_string(element.count);
      for (size_t p = 0; p < element.properties.size(); ++p) {
        const Property& property = element.properties[p];
        if (!property.is_list) {
          values[p] = reader.read(property.type, where);
          continue;
        }
        // A count read as an ASCII number or declared float (3e29, -1, 2.5)
        // must not reach the cast to long (found by the ply fuzz target).
        const double items = reader.read(property.count_type, where);
        if (!(items >= 0 && items == std::trunc(items) && items <= std::numeric_limits<std::uint32_t>::max()))
          throw InputError(path, 0, where + ": list " + property.name + " has a count of " + std::to_string(items) +
                                        ", not an integer in 0..4294967295");
        for (long item = 0; item < static_cast<long>(items); ++item) reader.read(property.type, where);
      }
      if (!is_vertex) continue;
      PlyPoint point;
      point.position = Vec3(values[x], values[y], values[z]);
      if (!point.position.allFinite()) throw InputError(path, 0, where + ": x, y or z is not a finite number");
      if (red >= 0 && green >= 0 && blue >= 0)
        point.bgr = cv::Vec3b(colourByte(values[blue], element.properties[blue].type),
                              colourByte(values[green], element.properties[green].type),
                              colourByte(values[red], element.properties[red].type));
      if (class_id >= 0) {
        const double id = values[class_id];
        // A float class_id of 1e30 does not fit an int (found by the ply fuzz target).
        if (!(id == std::trunc(id) && id >= std::numeric_limits<int>::min() && id <= std::numeric_limits<int>::max()))
          throw InputError(path, 0, where + ": class_id " + std::to_string(id) + " is not an int");
        point.class_id = static_cast<int>(id);
      }
      points.push_back(point);
    }
    found_vertices = found_vertices || is_vertex;
  }
  if (!found_vertices) throw InputError(path, 0, "no vertex element in the PLY header");
  return points;
}

}  // namespace vslam
