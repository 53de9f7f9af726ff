// libFuzzer target: see fuzz_entry_points.hpp for what it reads.
#include "fuzz_entry_points.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  vslam::fuzz::fuzzDepthPng(data, size);
  return 0;
}
