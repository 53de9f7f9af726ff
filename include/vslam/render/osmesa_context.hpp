#pragma once
// An off-screen OpenGL context (Mesa's software rasteriser through OSMesa):
// renders need no window system and no GPU. Fixed-function GL 1.x calls work
// after construction; the context is current on the constructing thread.
#include <vector>

#include <opencv2/core.hpp>

struct osmesa_context;  // OSMesa's opaque handle (GL/osmesa.h: OSMesaContext)

namespace vslam {

class OsmesaContext {
 public:
  // RGBA colour, 24-bit depth buffer, no stencil. Throws std::runtime_error
  // when OSMesa cannot create or bind the context.
  OsmesaContext(int width, int height);
  ~OsmesaContext();
  OsmesaContext(const OsmesaContext&) = delete;
  OsmesaContext& operator=(const OsmesaContext&) = delete;

  int width() const { return width_; }
  int height() const { return height_; }

  // Binds this context to the calling thread (needed only when several
  // contexts are alive and one switches between them).
  void makeCurrent();

  // Finishes pending GL work and returns the frame as CV_8UC3 BGR, row 0 at the top.
  cv::Mat readPixels();

  // Finishes pending GL work and returns the depth buffer's window depth (0 at
  // the near plane, 1 at the far plane or where nothing was drawn) as CV_32F,
  // row 0 at the top. Only the bottom-left width x height pixels are read, the
  // area a pass drawn with glViewport(0, 0, width, height) covers.
  cv::Mat readDepth(int width, int height);

 private:
  int width_;
  int height_;
  std::vector<unsigned char> colour_buffer_;  // OSMesa draws into this memory
  osmesa_context* context_ = nullptr;
};

}  // namespace vslam
