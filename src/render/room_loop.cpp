#include "vslam/render/room_loop.hpp"

#include <GL/gl.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "vslam/core/error.hpp"
#include "vslam/io/trajectory_io.hpp"
#include "vslam/render/osmesa_context.hpp"

namespace vslam {
namespace {

// Views are drawn at this multiple of the output size and averaged down: the
// anti-aliasing a real lens gives, so corners do not crawl from frame to frame.
constexpr int kSupersampling = 2;
// Depth is drawn at the output size into a corner of the supersampled buffer.
static_assert(kSupersampling >= 1, "the depth pass needs a buffer at least the camera's size");
// The 24-bit depth buffer resolves z to about z^2 / kNearPlane / 2^24 (0.03 mm
// at 5 m); with Mesa's rounding the room's depth is within 0.08 mm, under the
// 0.2 mm step of a TUM depth image.
constexpr double kNearPlane = 0.05;
constexpr double kFarPlane = 50.0;

struct Panel {
  std::array<Vec3, 4> corners;  // texture corners (0,0), (1,0), (1,1), (0,1)
  GLuint texture = 0;
};

// Random shapes in random colours over a random two-colour gradient: many
// corners for ORB, and no two panels alike.
cv::Mat drawPanelTexture(int size, cv::RNG& rng) {
  auto colour = [&rng] { return cv::Scalar(rng.uniform(0, 256), rng.uniform(0, 256), rng.uniform(0, 256)); };
  cv::Mat texture(size, size, CV_8UC3);
  const cv::Scalar from = colour(), to = colour();
  for (int row = 0; row < size; ++row)
    texture.row(row).setTo(from + (to - from) * (static_cast<double>(row) / size));
  const int shapes = size * size / 1200;
  for (int i = 0; i < shapes; ++i) {
    const cv::Point centre(rng.uniform(0, size), rng.uniform(0, size));
    const int extent = rng.uniform(size / 60, size / 8);
    switch (rng.uniform(0, 4)) {
      case 0:
        cv::rectangle(texture, centre, centre + cv::Point(rng.uniform(4, extent), rng.uniform(4, extent)), colour(),
                      cv::FILLED, cv::LINE_AA);
        break;
      case 1:
        cv::circle(texture, centre, extent / 2, colour(), cv::FILLED, cv::LINE_AA);
        break;
      case 2: {
        std::array<cv::Point, 3> triangle;
        for (cv::Point& corner : triangle)
          corner = centre + cv::Point(rng.uniform(-extent, extent), rng.uniform(-extent, extent));
        cv::fillConvexPoly(texture, triangle.data(), 3, colour(), cv::LINE_AA);
        break;
      }
      default:
        cv::line(texture, centre, centre + cv::Point(rng.uniform(-extent, extent), rng.uniform(-extent, extent)),
                 colour(), rng.uniform(2, 6), cv::LINE_AA);
    }
  }
  return texture;
}

// A mipmapped, edge-clamped GL texture of a BGR image; returns its name.
GLuint uploadTexture(const cv::Mat& bgr) {
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  GLuint texture = 0;
  glGenTextures(1, &texture);
  glBindTexture(GL_TEXTURE_2D, texture);
  glTexParameteri(GL_TEXTURE_2D, GL_GENERATE_MIPMAP, GL_TRUE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB, rgb.cols, rgb.rows, 0, GL_RGB, GL_UNSIGNED_BYTE, rgb.data);
  return texture;
}

// Splits the rectangle origin + a*u + b*v (a, b in [0, 1]) into n_u x n_v panels.
void addPanels(const Vec3& origin, const Vec3& u, const Vec3& v, int n_u, int n_v, std::vector<Panel>& panels) {
  for (int i = 0; i < n_u; ++i)
    for (int j = 0; j < n_v; ++j) {
      const Vec3 a = origin + u * (static_cast<double>(i) / n_u) + v * (static_cast<double>(j) / n_v);
      const Vec3 du = u / n_u, dv = v / n_v;
      panels.push_back({{a, a + du, a + du + dv, a + dv}, 0});
    }
}

// Viewport, projection and model-view for `camera` drawn `scale` times its
// size, from camera-to-world pose T_wc.
void loadCamera(const PinholeCamera& camera, double scale, const SE3& T_wc) {
  const double width = camera.width * scale, height = camera.height * scale;
  // Intrinsics at the drawn size. A pixel's centre is at window coordinate i + 0.5,
  // and at pixel coordinate (i + 0.5) / scale - 0.5 once averaged down.
  const double fx = camera.fx * scale, fy = camera.fy * scale;
  const double cx = (camera.cx + 0.5) * scale, cy = (camera.cy + 0.5) * scale;
  glViewport(0, 0, static_cast<GLsizei>(width), static_cast<GLsizei>(height));

  // glFrustum from the pinhole: image rows grow downwards, GL's y upwards (the
  // read-back flips rows), and GL's camera looks along -z.
  glMatrixMode(GL_PROJECTION);
  glLoadIdentity();
  const double n = kNearPlane;
  glFrustum(-cx * n / fx, (width - cx) * n / fx, -(height - cy) * n / fy, cy * n / fy, n, kFarPlane);

  // Model-view: world -> OpenCV camera (T_cw), then OpenCV -> GL axes (y and z flipped).
  const SE3 T_cw = T_wc.inverse();
  Mat4 view = Mat4::Identity();
  view.topLeftCorner<3, 3>() = T_cw.R;
  view.topRightCorner<3, 1>() = T_cw.t;
  view.row(1) *= -1.0;
  view.row(2) *= -1.0;
  glMatrixMode(GL_MODELVIEW);
  glLoadMatrixd(view.data());  // Eigen is column-major, as GL expects
}

void drawPanels(const std::vector<Panel>& panels, bool textured) {
  if (textured) {
    glEnable(GL_TEXTURE_2D);
    glTexEnvi(GL_TEXTURE_ENV, GL_TEXTURE_ENV_MODE, GL_REPLACE);
  }
  constexpr std::array<std::array<float, 2>, 4> kTexCoords = {{{0.f, 0.f}, {1.f, 0.f}, {1.f, 1.f}, {0.f, 1.f}}};
  for (const Panel& panel : panels) {
    if (textured) glBindTexture(GL_TEXTURE_2D, panel.texture);
    glBegin(GL_QUADS);
    for (int c = 0; c < 4; ++c) {
      if (textured) glTexCoord2f(kTexCoords[c][0], kTexCoords[c][1]);
      glVertex3d(panel.corners[c].x(), panel.corners[c].y(), panel.corners[c].z());
    }
    glEnd();
  }
  if (textured) glDisable(GL_TEXTURE_2D);
}

}  // namespace

PinholeCamera RoomLoopParams::defaultCamera() {
  PinholeCamera camera;
  camera.name = "synthetic_room";
  camera.width = 640;
  camera.height = 480;
  camera.fx = camera.fy = 525.0;
  camera.cx = 319.5;
  camera.cy = 239.5;
  camera.fps = 30.0;
  // RGB-D as ORB-SLAM2 runs TUM: a virtual baseline of 40 / fx (7.6 cm),
  // depth trusted as stereo closer than 40 baselines (3 m).
  camera.depth_factor = 5000.0;
  camera.bf = 40.0;
  camera.th_depth = 40.0;
  camera.max_depth_m = 10.0;
  return camera;
}

namespace {

// The camera's pose at frame k of the circle.
StampedPose roomLoopPose(const RoomLoopParams& params, int k) {
  const double total_angle = 2.0 * M_PI * params.turns;
  const double angle = params.frames > 1 ? total_angle * k / (params.frames - 1) : 0.0;
  const Vec3 outward(std::cos(angle), 0.0, std::sin(angle));
  const Vec3 centre = params.path_radius_m * outward + Vec3(0.0, params.bob_m * std::sin(2.0 * angle), 0.0);
  // Camera axes in the world: z looks outwards, y is down, x = y cross z.
  Mat3 R_wc;
  R_wc.col(2) = outward;
  R_wc.col(1) = Vec3(0.0, 1.0, 0.0);
  R_wc.col(0) = R_wc.col(1).cross(R_wc.col(2));
  return {params.start_time_s + k / params.camera.fps, SE3(R_wc, centre)};
}

}  // namespace

std::vector<StampedPose> roomLoopPath(const RoomLoopParams& params) {
  std::vector<StampedPose> path;
  for (int k = 0; k < params.frames; ++k) path.push_back(roomLoopPose(params, k));
  return path;
}

std::array<Vec3, 4> movingObjectCorners(const RoomLoopParams& params, int frame, double aspect) {
  const int first = params.moving_object_first_frame;
  const int crossing = std::max(1, params.moving_object_frames);
  const int last = params.frames - 1;
  // Where it is in its crossing, held at either end.
  const int k = std::clamp(std::clamp(frame, first, first + crossing), 0, std::max(last, 0));
  const double progress = static_cast<double>(k - first) / crossing;
  // The camera's heading at that frame (so the object keeps in view while the
  // camera turns), plus a bearing that sweeps across the view.
  const Vec3 view = roomLoopPose(params, k).T_wc.R.col(2);
  const double heading = std::atan2(view.z(), view.x());
  const double bearing = (0.5 - progress) * params.moving_object_sweep_deg * M_PI / 180.0;
  const double angle = heading + bearing;
  const Vec3 outward(std::cos(angle), 0.0, std::sin(angle));
  const Vec3 centre = params.moving_object_radius_m * outward;
  // Upright, facing the room's centre: right-hand edge along y x outward.
  const Vec3 across = Vec3(0.0, 1.0, 0.0).cross(outward).normalized();
  const double half_width = 0.5 * params.moving_object_width_m;
  const double half_height = 0.5 * params.moving_object_width_m * aspect;
  const Vec3 up(0.0, -1.0, 0.0);  // y is down
  return {centre - across * half_width + up * half_height, centre + across * half_width + up * half_height,
          centre + across * half_width - up * half_height, centre - across * half_width - up * half_height};
}

struct RoomLoopRenderer::Scene {
  RoomLoopParams params;
  OsmesaContext context;
  std::vector<Panel> panels;
  Panel moving_object;  // texture 0 when there is none
  double moving_object_aspect = 1.0;

  explicit Scene(const RoomLoopParams& p)
      : params(p), context(p.camera.width * kSupersampling, p.camera.height * kSupersampling) {}
};

RoomLoopRenderer::RoomLoopRenderer(const RoomLoopParams& params) : scene_(std::make_unique<Scene>(params)) {
  const double w = params.room_half_width_m;
  const double top = params.ceiling_y_m, bottom = params.floor_y_m;
  const int n = params.panels_per_wall;
  std::vector<Panel>& panels = scene_->panels;
  // Four walls, each seen from inside; then floor and ceiling in n x n tiles.
  addPanels(Vec3(-w, top, w), Vec3(2 * w, 0, 0), Vec3(0, bottom - top, 0), n, 1, panels);    // z = +w
  addPanels(Vec3(w, top, w), Vec3(0, 0, -2 * w), Vec3(0, bottom - top, 0), n, 1, panels);    // x = +w
  addPanels(Vec3(w, top, -w), Vec3(-2 * w, 0, 0), Vec3(0, bottom - top, 0), n, 1, panels);   // z = -w
  addPanels(Vec3(-w, top, -w), Vec3(0, 0, 2 * w), Vec3(0, bottom - top, 0), n, 1, panels);   // x = -w
  addPanels(Vec3(-w, bottom, -w), Vec3(2 * w, 0, 0), Vec3(0, 0, 2 * w), n, n, panels);       // floor
  addPanels(Vec3(-w, top, -w), Vec3(2 * w, 0, 0), Vec3(0, 0, 2 * w), n, n, panels);          // ceiling

  cv::RNG rng(params.seed);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  for (Panel& panel : panels) panel.texture = uploadTexture(drawPanelTexture(params.texture_px, rng));
  if (!params.moving_object_image.empty()) {
    const cv::Mat image = cv::imread(params.moving_object_image, cv::IMREAD_COLOR);
    if (image.empty())
      throw InputError(params.moving_object_image + ": not a readable image (the moving object's picture)");
    scene_->moving_object_aspect = static_cast<double>(image.rows) / image.cols;
    scene_->moving_object.texture = uploadTexture(image);
    setFrame(0);
  }
  if (glGetError() != GL_NO_ERROR) throw std::runtime_error("RoomLoopRenderer: OpenGL refused the panel textures");
}

void RoomLoopRenderer::setFrame(int frame) {
  if (scene_->moving_object.texture == 0) return;
  scene_->moving_object.corners = movingObjectCorners(scene_->params, frame, scene_->moving_object_aspect);
}

RoomLoopRenderer::~RoomLoopRenderer() {
  scene_->context.makeCurrent();
  for (Panel& panel : scene_->panels) glDeleteTextures(1, &panel.texture);
  if (scene_->moving_object.texture != 0) glDeleteTextures(1, &scene_->moving_object.texture);
}

cv::Mat RoomLoopRenderer::render(const SE3& T_wc) {
  OsmesaContext& context = scene_->context;
  context.makeCurrent();
  const PinholeCamera& camera = scene_->params.camera;
  glClearColor(0.f, 0.f, 0.f, 1.f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDisable(GL_LIGHTING);
  glDisable(GL_CULL_FACE);
  loadCamera(camera, kSupersampling, T_wc);
  drawPanels(scene_->panels, true);
  if (scene_->moving_object.texture != 0) drawPanels({scene_->moving_object}, true);

  cv::Mat drawn = context.readPixels();
  cv::Mat image;
  cv::resize(drawn, image, cv::Size(camera.width, camera.height), 0, 0, cv::INTER_AREA);
  return image;
}

cv::Mat RoomLoopRenderer::renderDepth(const SE3& T_wc) {
  OsmesaContext& context = scene_->context;
  context.makeCurrent();
  const PinholeCamera& camera = scene_->params.camera;
  glClear(GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  // Only depth is read back, so colour writes (and textures) are skipped.
  glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
  loadCamera(camera, 1.0, T_wc);
  drawPanels(scene_->panels, false);
  if (scene_->moving_object.texture != 0) drawPanels({scene_->moving_object}, false);
  glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  const cv::Mat window_depth = context.readDepth(camera.width, camera.height);

  // Window depth d of glFrustum(n, f) back to camera z: z = n f / (f - d (f - n)).
  const double n = kNearPlane, f = kFarPlane;
  cv::Mat depth(window_depth.size(), CV_32F);
  for (int row = 0; row < depth.rows; ++row) {
    const float* d = window_depth.ptr<float>(row);
    float* z = depth.ptr<float>(row);
    for (int col = 0; col < depth.cols; ++col)
      z[col] = d[col] < 1.f ? static_cast<float>(n * f / (f - d[col] * (f - n))) : 0.f;  // 1 = cleared
  }
  return depth;
}

cv::Mat encodeTumDepth(const cv::Mat& depth_m, double depth_factor) {
  CV_Assert(depth_m.type() == CV_32FC1 && depth_factor > 0);
  cv::Mat raw(depth_m.size(), CV_16UC1);
  for (int row = 0; row < raw.rows; ++row) {
    const float* metres = depth_m.ptr<float>(row);
    uint16_t* units = raw.ptr<uint16_t>(row);
    for (int col = 0; col < raw.cols; ++col) {
      const double value = std::round(metres[col] * depth_factor);
      // Out of range reads as no measurement, as a sensor reports it, not as the largest value.
      units[col] = value > 0 && value <= 65535 ? static_cast<uint16_t>(value) : 0;
    }
  }
  return raw;
}

void writeRoomLoopSequence(const RoomLoopParams& params, const std::string& folder,
                           const std::function<void(int, int)>& progress) {
  namespace fs = std::filesystem;
  const fs::path root(folder);
  fs::create_directories(root / "rgb");
  fs::create_directories(root / "depth");
  const std::vector<StampedPose> path = roomLoopPath(params);
  RoomLoopRenderer renderer(params);

  std::ofstream rgb_list(root / "rgb.txt"), depth_list(root / "depth.txt");
  if (!rgb_list) throw std::runtime_error("cannot write " + (root / "rgb.txt").string());
  if (!depth_list) throw std::runtime_error("cannot write " + (root / "depth.txt").string());
  rgb_list << "# synthetic room loop: " << params.frames << " frames, " << params.turns << " turns, seed "
           << params.seed << "\n# timestamp filename\n";
  depth_list << "# synthetic room loop: camera z in metres times " << params.camera.depth_factor
             << ", 0 = nothing drawn\n# timestamp filename\n";
  std::ofstream object_list;
  if (!params.moving_object_image.empty()) {
    object_list.open(root / "moving_object.txt");
    if (!object_list) throw std::runtime_error("cannot write " + (root / "moving_object.txt").string());
    object_list << "# the moving billboard (" << params.moving_object_image << "): timestamp, centre x y z (m)\n";
  }
  for (size_t k = 0; k < path.size(); ++k) {
    renderer.setFrame(static_cast<int>(k));
    char stamp[32];
    std::snprintf(stamp, sizeof stamp, "%.6f", path[k].timestamp);
    // The same timestamp for both, so the TUM association pairs every frame exactly.
    const std::string rgb_name = std::string("rgb/") + stamp + ".png";
    const std::string depth_name = std::string("depth/") + stamp + ".png";
    if (!cv::imwrite((root / rgb_name).string(), renderer.render(path[k].T_wc)))
      throw std::runtime_error("cannot write " + (root / rgb_name).string());
    const cv::Mat depth = encodeTumDepth(renderer.renderDepth(path[k].T_wc), params.camera.depth_factor);
    if (!cv::imwrite((root / depth_name).string(), depth))
      throw std::runtime_error("cannot write " + (root / depth_name).string());
    rgb_list << stamp << " " << rgb_name << "\n";
    if (object_list.is_open()) {
      // The centre does not depend on the billboard's aspect ratio.
      const std::array<Vec3, 4> corners = movingObjectCorners(params, static_cast<int>(k), 1.0);
      const Vec3 centre = 0.25 * (corners[0] + corners[1] + corners[2] + corners[3]);
      object_list << stamp << " " << centre.x() << " " << centre.y() << " " << centre.z() << "\n";
    }
    depth_list << stamp << " " << depth_name << "\n";
    if (progress) progress(static_cast<int>(k + 1), static_cast<int>(path.size()));
  }
  rgb_list.close();
  if (!rgb_list) throw std::runtime_error("cannot write " + (root / "rgb.txt").string());
  depth_list.close();
  if (!depth_list) throw std::runtime_error("cannot write " + (root / "depth.txt").string());
  writeTumTrajectory((root / "groundtruth.txt").string(), path);

  const PinholeCamera& c = params.camera;
  std::ofstream yaml(root / "camera.yaml");
  yaml.precision(10);
  yaml << "# The synthetic room's pinhole camera (no distortion).\ncamera:\n"
       << "  name: " << c.name << "\n  width: " << c.width << "\n  height: " << c.height << "\n  fx: " << c.fx
       << "\n  fy: " << c.fy << "\n  cx: " << c.cx << "\n  cy: " << c.cy << "\n  fps: " << c.fps << "\n"
       << "  # depth/*.png: metres times depth_factor. bf = fx times a virtual stereo baseline (m);\n"
       << "  # depth closer than th_depth baselines counts as close, beyond max_depth_m is dropped.\n"
       << "  depth_factor: " << c.depth_factor << "\n  bf: " << c.bf << "\n  th_depth: " << c.th_depth
       << "\n  max_depth_m: " << c.max_depth_m << "\n";
  if (!yaml) throw std::runtime_error("cannot write " + (root / "camera.yaml").string());
}

}  // namespace vslam
