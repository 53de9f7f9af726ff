#include "vslam/render/osmesa_context.hpp"

#include <stdexcept>
#include <string>

#include <GL/osmesa.h>
#include <GL/gl.h>
#include <opencv2/imgproc.hpp>

namespace vslam {

OsmesaContext::OsmesaContext(int width, int height)
    : width_(width), height_(height), colour_buffer_(static_cast<size_t>(width) * height * 4) {
  if (width <= 0 || height <= 0)
    throw std::runtime_error("OsmesaContext: invalid size " + std::to_string(width) + "x" + std::to_string(height));
  context_ = OSMesaCreateContextExt(OSMESA_RGBA, 24, 0, 0, nullptr);
  if (!context_) throw std::runtime_error("OSMesaCreateContextExt failed (is libOSMesa installed?)");
  makeCurrent();
}

OsmesaContext::~OsmesaContext() {
  if (context_) OSMesaDestroyContext(context_);
}

void OsmesaContext::makeCurrent() {
  if (!OSMesaMakeCurrent(context_, colour_buffer_.data(), GL_UNSIGNED_BYTE, width_, height_)) {
    OSMesaDestroyContext(context_);
    context_ = nullptr;
    throw std::runtime_error("OSMesaMakeCurrent failed for a " + std::to_string(width_) + "x" +
                             std::to_string(height_) + " buffer");
  }
}

cv::Mat OsmesaContext::readPixels() {
  makeCurrent();
  glFinish();
  cv::Mat rgba(height_, width_, CV_8UC4);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data);
  cv::Mat bgr;
  cv::cvtColor(rgba, bgr, cv::COLOR_RGBA2BGR);
  cv::flip(bgr, bgr, 0);  // GL's row 0 is the bottom of the image
  return bgr;
}

cv::Mat OsmesaContext::readDepth(int width, int height) {
  if (width <= 0 || height <= 0 || width > width_ || height > height_)
    throw std::runtime_error("OsmesaContext::readDepth: " + std::to_string(width) + "x" + std::to_string(height) +
                             " does not fit the " + std::to_string(width_) + "x" + std::to_string(height_) + " buffer");
  makeCurrent();
  glFinish();
  cv::Mat depth(height, width, CV_32F);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width, height, GL_DEPTH_COMPONENT, GL_FLOAT, depth.data);
  cv::flip(depth, depth, 0);  // bottom row first, as for colour
  return depth;
}

}  // namespace vslam
