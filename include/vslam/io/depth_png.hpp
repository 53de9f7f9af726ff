#pragma once
// Fast decoding of the 16-bit greyscale PNGs that hold TUM-format depth images
// (TUM RGB-D, Bonn RGB-D Dynamic, `vslam synth`). OpenCV's libpng path spends
// most of its time in zlib's inflate; libdeflate inflates the same stream
// several times faster (docs/BENCHMARKS.md, "Depth image decoding"), which
// matters on 2 cores where the image loader shares the CPU with Tracking.
#include <cstddef>
#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

namespace vslam {

// Decodes a PNG held in memory when it is 16-bit greyscale, not interlaced and
// without a transparency chunk: returns a CV_16UC1 image equal to what
// cv::imdecode(..., cv::IMREAD_UNCHANGED) gives. Returns an empty Mat for any
// other PNG (or bytes that are no PNG), which the caller then hands to OpenCV.
// Throws InputError naming `file` when the PNG is of that kind but corrupt: a
// chunk cut short or failing its CRC, image data that does not inflate to
// exactly the image's size, an unknown row filter, an image over 2^28 bytes.
cv::Mat decodeGray16Png(const std::uint8_t* data, std::size_t size, const std::string& file);

}  // namespace vslam
