#pragma once
// The camera that tests on hand-built keyframes share: a VGA pinhole camera
// without distortion. Their ORB pyramid is makeScalePyramid's
// (vslam/map_io/map_database.hpp), the extractor's own.
#include "vslam/core/camera.hpp"

namespace vslam::test {

inline PinholeCamera vgaCamera() {
  PinholeCamera camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = camera.fy = 500;
  camera.cx = 320;
  camera.cy = 240;
  return camera;
}

}  // namespace vslam::test
