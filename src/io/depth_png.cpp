#include "vslam/io/depth_png.hpp"

#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include <libdeflate.h>

#include "vslam/core/error.hpp"

namespace vslam {
namespace {

constexpr std::uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
constexpr std::size_t kMaxImageBytes = std::size_t(1) << 28;
constexpr std::size_t kMaxDeflateRatio = 1032;
constexpr int kBytesPerPixel = 2;  // 16-bit greyscale: the filters' "left" is two bytes back

std::uint32_t bigEndian32(const std::uint8_t* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | std::uint32_t(p[3]);
}

struct Chunk {
  const std::uint8_t* type;  // 4 bytes
  const std::uint8_t* data;
  std::uint32_t length;
};

bool isType(const Chunk& chunk, const char* type) { return std::memcmp(chunk.type, type, 4) == 0; }

// The Paeth predictor in its difference form (|p - a| = |b - c| and so on for
// p = a + b - c), which compiles to conditional moves: it is most rows of a
// TUM depth image, so it is most of the decoding time.
inline std::uint8_t paeth(int left, int up, int up_left) {
  const int to_left = std::abs(up - up_left), to_up = std::abs(left - up_left),
            to_up_left = std::abs(left + up - 2 * up_left);
  const int nearer_up = to_up <= to_up_left ? up : up_left;
  return static_cast<std::uint8_t>(to_left <= to_up && to_left <= to_up_left ? left : nearer_up);
}

// Sub and Paeth chain each byte to the one a pixel to its left. The two bytes
// of a 16-bit pixel are two independent chains, and their last values are
// kept in registers: reading them back from the row just written made every
// step wait for the store (docs/BENCHMARKS.md, "Depth image decoding").
// row_bytes is even: whole 16-bit pixels.
void unfilterSub(std::uint8_t* row, std::size_t row_bytes) {
  if (row_bytes < kBytesPerPixel) return;
  std::uint8_t high = row[0], low = row[1];
  for (std::size_t i = kBytesPerPixel; i + 1 < row_bytes; i += kBytesPerPixel) {
    high = row[i] = static_cast<std::uint8_t>(row[i] + high);
    low = row[i + 1] = static_cast<std::uint8_t>(row[i + 1] + low);
  }
}

// The first pixel has nothing to its left: Paeth gives Up there.
void unfilterPaeth(std::uint8_t* row, const std::uint8_t* up, std::size_t row_bytes) {
  if (row_bytes < kBytesPerPixel) return;
  std::uint8_t high = row[0] = static_cast<std::uint8_t>(row[0] + up[0]);
  std::uint8_t low = row[1] = static_cast<std::uint8_t>(row[1] + up[1]);
  for (std::size_t i = kBytesPerPixel; i + 1 < row_bytes; i += kBytesPerPixel) {
    high = row[i] = static_cast<std::uint8_t>(row[i] + paeth(high, up[i], up[i - kBytesPerPixel]));
    low = row[i + 1] = static_cast<std::uint8_t>(row[i + 1] + paeth(low, up[i + 1], up[i + 1 - kBytesPerPixel]));
  }
}

// Undoes the row filters in place (PNG specification, section 9); `rows` holds
// each row's filter byte followed by its `row_bytes` bytes.
void unfilterRows(std::uint8_t* rows, int height, std::size_t row_bytes, const std::string& file) {
  const std::size_t stride = row_bytes + 1;
  for (int y = 0; y < height; ++y) {
    std::uint8_t* row = rows + y * stride + 1;
    const std::uint8_t* up = y > 0 ? rows + (y - 1) * stride + 1 : nullptr;
    const int filter = row[-1];
    switch (filter) {
      case 0:
        break;
      case 1:  // Sub
        unfilterSub(row, row_bytes);
        break;
      case 2:  // Up
        if (up)
          for (std::size_t i = 0; i < row_bytes; ++i) row[i] += up[i];
        break;
      case 3:  // Average
        for (std::size_t i = 0; i < row_bytes; ++i) {
          const int left = i >= kBytesPerPixel ? row[i - kBytesPerPixel] : 0;
          row[i] += static_cast<std::uint8_t>((left + (up ? up[i] : 0)) / 2);
        }
        break;
      case 4:  // Paeth; in the first row (nothing above) it is Sub
        if (up)
          unfilterPaeth(row, up, row_bytes);
        else
          unfilterSub(row, row_bytes);
        break;
      default:
        throw InputError(file, 0, "corrupt PNG: row " + std::to_string(y) + " has unknown filter type " +
                                      std::to_string(filter));
    }
  }
}

}  // namespace

cv::Mat decodeGray16Png(const std::uint8_t* data, std::size_t size, const std::string& file) {
  if (size < sizeof(kSignature) || std::memcmp(data, kSignature, sizeof(kSignature)) != 0) return cv::Mat();

  // Walk the chunks; IHDR must come first.
  std::vector<Chunk> chunks;
  std::size_t offset = sizeof(kSignature);
  while (offset < size) {
    if (size - offset < 12) throw InputError(file, 0, "corrupt PNG: chunk header cut short at byte " + std::to_string(offset));
    const std::uint32_t length = bigEndian32(data + offset);
    if (length > size - offset - 12)
      throw InputError(file, 0, "corrupt PNG: chunk at byte " + std::to_string(offset) + " runs past the end of the file");
    const Chunk chunk{data + offset + 4, data + offset + 8, length};
    // Critical chunks (upper-case first letter) must pass their CRC, as libpng requires.
    const bool critical = (chunk.type[0] & 0x20) == 0;
    if (critical && libdeflate_crc32(0, chunk.type, length + 4) != bigEndian32(chunk.data + length))
      throw InputError(file, 0,
                       "corrupt PNG: CRC mismatch in the " + std::string(reinterpret_cast<const char*>(chunk.type), 4) +
                           " chunk at byte " + std::to_string(offset));
    chunks.push_back(chunk);
    offset += 12 + std::size_t(length);
    if (isType(chunk, "IEND")) break;
  }
  if (chunks.empty() || !isType(chunks.front(), "IHDR") || chunks.front().length != 13)
    throw InputError(file, 0, "corrupt PNG: it does not start with a 13-byte IHDR chunk");
  const std::uint8_t* header = chunks.front().data;
  const std::uint32_t width = bigEndian32(header), height = bigEndian32(header + 4);
  const int bit_depth = header[8], colour_type = header[9], interlace = header[12];
  if (bit_depth != 16 || colour_type != 0 || interlace != 0) return cv::Mat();  // not ours: OpenCV decodes it
  if (header[10] != 0 || header[11] != 0)
    throw InputError(file, 0, "corrupt PNG: unknown compression or filter method in IHDR");
  if (width == 0 || height == 0) throw InputError(file, 0, "corrupt PNG: the image is empty (IHDR)");
  const std::size_t row_bytes = std::size_t(width) * kBytesPerPixel;
  if (width > kMaxImageBytes / kBytesPerPixel || (row_bytes + 1) > kMaxImageBytes / height)
    throw InputError(file, 0,
                     "PNG of " + std::to_string(width) + "x" + std::to_string(height) + " is too large for a depth image");

  std::vector<std::uint8_t> compressed;
  bool ended = false;
  for (const Chunk& chunk : chunks) {
    if (isType(chunk, "tRNS")) return cv::Mat();  // transparency: leave it to OpenCV
    if (isType(chunk, "IDAT")) compressed.insert(compressed.end(), chunk.data, chunk.data + chunk.length);
    ended = ended || isType(chunk, "IEND");
  }
  if (!ended) throw InputError(file, 0, "truncated PNG: no IEND chunk");
  if (compressed.empty()) throw InputError(file, 0, "corrupt PNG: no IDAT chunk");

  // Deflate cannot compress more than 1032:1, so a short stream is refused
  // before the image's memory is allocated.
  const std::size_t image_bytes = (row_bytes + 1) * height;
  if (image_bytes / kMaxDeflateRatio > compressed.size())
    throw InputError(file, 0,
                     "corrupt PNG: " + std::to_string(compressed.size()) + " bytes of image data cannot hold " +
                         std::to_string(width) + "x" + std::to_string(height) + " 16-bit pixels");
  // Left uninitialised: a successful inflate writes every byte (see below).
  std::unique_ptr<std::uint8_t[]> rows(new std::uint8_t[image_bytes]);
  std::unique_ptr<libdeflate_decompressor, decltype(&libdeflate_free_decompressor)> inflater(
      libdeflate_alloc_decompressor(), &libdeflate_free_decompressor);
  if (!inflater) throw std::bad_alloc();
  // A null actual size asks for exactly image_bytes bytes: fewer or more is an error.
  const libdeflate_result result =
      libdeflate_zlib_decompress(inflater.get(), compressed.data(), compressed.size(), rows.get(), image_bytes, nullptr);
  if (result != LIBDEFLATE_SUCCESS)
    throw InputError(file, 0,
                     result == LIBDEFLATE_BAD_DATA ? "corrupt PNG: its image data does not inflate"
                                                   : "corrupt PNG: its image data does not inflate to " +
                                                         std::to_string(width) + "x" + std::to_string(height) +
                                                         " 16-bit pixels");
  unfilterRows(rows.get(), static_cast<int>(height), row_bytes, file);

  cv::Mat image(static_cast<int>(height), static_cast<int>(width), CV_16UC1);
  for (int y = 0; y < image.rows; ++y) {
    const std::uint8_t* row = rows.get() + y * (row_bytes + 1) + 1;
    auto* out = image.ptr<std::uint16_t>(y);
    for (int x = 0; x < image.cols; ++x) out[x] = static_cast<std::uint16_t>((row[2 * x] << 8) | row[2 * x + 1]);
  }
  return image;
}

}  // namespace vslam
