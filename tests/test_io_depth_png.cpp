// io::decodeGray16Png: the libdeflate decoder of 16-bit depth PNGs gives
// exactly OpenCV's pixels, hands every other PNG back to OpenCV, and names the
// file and the fault of a corrupt one.
#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <libdeflate.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "sequence_test_support.hpp"
#include "test_support.hpp"
#include "vslam/core/error.hpp"
#include "vslam/io/depth_png.hpp"

namespace vslam {
namespace {

using Bytes = std::vector<std::uint8_t>;

void appendBigEndian32(Bytes& out, std::uint32_t value) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<std::uint8_t>(value >> shift));
}

void appendChunk(Bytes& out, const char* type, const Bytes& data) {
  appendBigEndian32(out, static_cast<std::uint32_t>(data.size()));
  Bytes typed(type, type + 4);
  typed.insert(typed.end(), data.begin(), data.end());
  out.insert(out.end(), typed.begin(), typed.end());
  appendBigEndian32(out, libdeflate_crc32(0, typed.data(), typed.size()));
}

int paethPredictor(int a, int b, int c) {
  const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  return pa <= pb && pa <= pc ? a : (pb <= pc ? b : c);
}

// A 16-bit greyscale PNG whose row y is filtered with filter_of(y) (0-4, or
// any other byte to write an invalid filter type), written independently of
// the decoder: filters applied forwards from the PNG specification.
template <typename FilterOf>
Bytes encodeGray16Png(const cv::Mat& image, FilterOf filter_of) {
  const size_t row_bytes = 2 * image.cols;
  std::vector<Bytes> raw(image.rows, Bytes(row_bytes));
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) {
      raw[y][2 * x] = static_cast<std::uint8_t>(image.at<std::uint16_t>(y, x) >> 8);
      raw[y][2 * x + 1] = static_cast<std::uint8_t>(image.at<std::uint16_t>(y, x) & 0xFF);
    }
  Bytes filtered;
  for (int y = 0; y < image.rows; ++y) {
    const int filter = filter_of(y);
    filtered.push_back(static_cast<std::uint8_t>(filter));
    for (size_t i = 0; i < row_bytes; ++i) {
      const int left = i >= 2 ? raw[y][i - 2] : 0, up = y > 0 ? raw[y - 1][i] : 0;
      const int up_left = i >= 2 && y > 0 ? raw[y - 1][i - 2] : 0;
      int predicted = 0;
      if (filter == 1) predicted = left;
      if (filter == 2) predicted = up;
      if (filter == 3) predicted = (left + up) / 2;
      if (filter == 4) predicted = paethPredictor(left, up, up_left);
      filtered.push_back(static_cast<std::uint8_t>(raw[y][i] - predicted));
    }
  }
  libdeflate_compressor* compressor = libdeflate_alloc_compressor(6);
  Bytes compressed(libdeflate_zlib_compress_bound(compressor, filtered.size()));
  compressed.resize(
      libdeflate_zlib_compress(compressor, filtered.data(), filtered.size(), compressed.data(), compressed.size()));
  libdeflate_free_compressor(compressor);

  Bytes png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  Bytes header;
  appendBigEndian32(header, image.cols);
  appendBigEndian32(header, image.rows);
  header.insert(header.end(), {16, 0, 0, 0, 0});  // 16-bit, greyscale, deflate, adaptive filters, not interlaced
  appendChunk(png, "IHDR", header);
  // Two IDAT chunks: the decoder must join them.
  const size_t half = compressed.size() / 2;
  appendChunk(png, "IDAT", Bytes(compressed.begin(), compressed.begin() + half));
  appendChunk(png, "IDAT", Bytes(compressed.begin() + half, compressed.end()));
  appendChunk(png, "IEND", {});
  return png;
}

cv::Mat randomDepth(int width, int height) {
  cv::Mat image(height, width, CV_16UC1);
  cv::RNG rng(7);
  rng.fill(image, cv::RNG::UNIFORM, 0, 65536);
  return image;
}

bool identical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

std::string decodeError(const Bytes& png) {
  try {
    decodeGray16Png(png.data(), png.size(), "d.png");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(IoDepthPng, EveryRowFilterDecodesToTheExactPixels) {
  const cv::Mat image = randomDepth(37, 11);
  const Bytes png = encodeGray16Png(image, [](int y) { return y % 5; });
  const cv::Mat decoded = decodeGray16Png(png.data(), png.size(), "d.png");
  EXPECT_TRUE(identical(decoded, image));
  // The hand-made file is a real PNG: OpenCV reads the same pixels from it.
  EXPECT_TRUE(identical(cv::imdecode(png, cv::IMREAD_UNCHANGED), image));
}

TEST(IoDepthPng, SharedDepthImagesDecodeAsOpenCvDecodesThem) {
  for (const char* name : {"tum/fr1_xyz", "tum/fr3_teddy", "bonn/crowd"}) {
    const Sequence sequence = test::openSharedSequence(name);
    int compared = 0;
    for (size_t i = 0; i < sequence.frames.size() && compared < 20; i += 7) {
      const std::string& path = sequence.frames[i].depth_path;
      if (path.empty()) continue;
      std::ifstream in(path, std::ios::binary);
      const Bytes bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      EXPECT_TRUE(identical(decodeGray16Png(bytes.data(), bytes.size(), path), cv::imread(path, cv::IMREAD_UNCHANGED)))
          << path;
      ++compared;
    }
    EXPECT_EQ(compared, 20) << name;
  }
}

TEST(IoDepthPng, OtherImagesAreLeftToOpenCv) {
  Bytes eight_bit;
  cv::imencode(".png", cv::Mat(4, 4, CV_8UC1, cv::Scalar(9)), eight_bit);
  EXPECT_TRUE(decodeGray16Png(eight_bit.data(), eight_bit.size(), "d.png").empty());
  Bytes colour;
  cv::imencode(".png", cv::Mat(4, 4, CV_16UC3, cv::Scalar(9, 9, 9)), colour);
  EXPECT_TRUE(decodeGray16Png(colour.data(), colour.size(), "d.png").empty());
  const Bytes not_png = {'J', 'P', 'E', 'G', 0, 1, 2, 3, 4, 5};
  EXPECT_TRUE(decodeGray16Png(not_png.data(), not_png.size(), "d.png").empty());
}

TEST(IoDepthPng, CorruptFilesAreErrorsNamingTheFileAndTheFault) {
  const cv::Mat image = randomDepth(8, 6);
  const Bytes good = encodeGray16Png(image, [](int) { return 0; });

  Bytes flipped = good;
  flipped[8 + 8 + 13 + 4 + 8 + 2] ^= 0x40;  // a byte inside the first IDAT's data
  EXPECT_NE(decodeError(flipped).find("d.png: corrupt PNG: CRC mismatch in the IDAT chunk"), std::string::npos)
      << decodeError(flipped);

  const Bytes cut(good.begin(), good.begin() + good.size() - 30);
  EXPECT_NE(decodeError(cut).find("d.png: corrupt PNG: chunk at byte"), std::string::npos) << decodeError(cut);

  const Bytes bad_filter = encodeGray16Png(image, [](int y) { return y == 3 ? 7 : 0; });
  EXPECT_EQ(decodeError(bad_filter), "d.png: corrupt PNG: row 3 has unknown filter type 7");

  // Rows of a 9-pixel-wide image in a header that says 8: too much data.
  Bytes wider = encodeGray16Png(randomDepth(9, 6), [](int) { return 0; });
  Bytes header(wider.begin() + 16, wider.begin() + 29);
  header[3] = 8;
  Bytes relabelled(wider.begin(), wider.begin() + 8);
  appendChunk(relabelled, "IHDR", header);
  relabelled.insert(relabelled.end(), wider.begin() + 8 + 25, wider.end());
  EXPECT_EQ(decodeError(relabelled), "d.png: corrupt PNG: its image data does not inflate to 8x6 16-bit pixels");

  // A header claiming 10000x10000 over a few bytes of data is refused before
  // 200 MB are allocated.
  Bytes huge_header = header;
  huge_header[2] = 0x27, huge_header[3] = 0x10, huge_header[6] = 0x27, huge_header[7] = 0x10;
  Bytes huge(wider.begin(), wider.begin() + 8);
  appendChunk(huge, "IHDR", huge_header);
  huge.insert(huge.end(), wider.begin() + 8 + 25, wider.end());
  EXPECT_NE(decodeError(huge).find("bytes of image data cannot hold 10000x10000 16-bit pixels"), std::string::npos)
      << decodeError(huge);
}

}  // namespace
}  // namespace vslam
