#pragma once
// The camera and ORB pyramid that tests on hand-built keyframes share: a VGA
// pinhole camera without distortion, and the paper's 8 levels at 1.2.
#include "vslam/core/camera.hpp"
#include "vslam/map/frame.hpp"

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

inline ScalePyramid scalePyramid(int levels = 8, double scale_factor = 1.2) {
  ScalePyramid pyramid;
  pyramid.levels = levels;
  pyramid.scale_factor = scale_factor;
  double scale = 1;
  for (int level = 0; level < levels; ++level, scale *= scale_factor) {
    pyramid.scale.push_back(scale);
    pyramid.sigma2.push_back(scale * scale);
    pyramid.inv_sigma2.push_back(1 / (scale * scale));
  }
  return pyramid;
}

}  // namespace vslam::test
