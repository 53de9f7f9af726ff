#pragma once
// Feeding a sequence to a System as `vslam run` does, for the end-to-end tests
// that run with the detector on.
#include <algorithm>
#include <limits>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/io/sequence.hpp"
#include "vslam/render/room_loop.hpp"
#include "vslam/slam/system.hpp"

namespace vslam::test {

// The first `count` frames of `sequence` (all by default), in order: the next
// colour image is submitted to detection ahead while this one is tracked, each
// image is decoded once, and with `with_depth` each frame that has a depth
// image gets it. Does not call finish().
inline void feedFrames(System& system, const Sequence& sequence, bool with_depth,
                       size_t count = std::numeric_limits<size_t>::max()) {
  const size_t n = std::min(count, sequence.frames.size());
  cv::Mat colour = n > 0 ? sequence.loadColor(0) : cv::Mat();
  for (size_t i = 0; i < n; ++i) {
    cv::Mat next;
    if (i + 1 < n) {
      next = sequence.loadColor(i + 1);
      system.submitAhead(sequence.frames[i + 1].index, next);
    }
    const bool has_depth = with_depth && !sequence.frames[i].depth_path.empty();
    system.processFrame(sequence.frames[i].index, sequence.frames[i].timestamp, colour,
                        has_depth ? sequence.loadDepthMeters(i, colour.size()) : cv::Mat());
    colour = next;
  }
}

// Frames [begin, end) of the synthetic room, rendered along `path`; with
// `with_depth` each gets its rendered depth through the TUM 16-bit encoding
// (factor 5000), as `vslam run` reads it. Does not call finish().
inline void feedRoom(System& system, RoomLoopRenderer& renderer, const std::vector<StampedPose>& path,
                     bool with_depth = false, size_t begin = 0,
                     size_t end = std::numeric_limits<size_t>::max()) {
  constexpr double kDepthFactor = 5000.0;
  for (size_t k = begin; k < std::min(end, path.size()); ++k) {
    cv::Mat depth;
    if (with_depth)
      encodeTumDepth(renderer.renderDepth(path[k].T_wc), kDepthFactor).convertTo(depth, CV_32F, 1.0 / kDepthFactor);
    system.processFrame(static_cast<int>(k), path[k].timestamp, renderer.render(path[k].T_wc), depth);
  }
}

}  // namespace vslam::test
