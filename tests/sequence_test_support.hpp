#pragma once
// A sequence from ../shared, as the end-to-end SLAM tests open it.
#include <string>

#include "test_support.hpp"
#include "vslam/io/sequence.hpp"

namespace vslam::test {

inline Sequence openSharedSequence(const std::string& name) {
  SequenceOptions options;
  options.data_root = sharedData().string();
  return openSequence(name, options);
}

}  // namespace vslam::test
