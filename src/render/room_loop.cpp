#include "vslam/render/room_loop.hpp"

#include <GL/gl.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "vslam/io/trajectory_io.hpp"
#include "vslam/render/osmesa_context.hpp"

namespace vslam {
namespace {

// Views are drawn at this multiple of the output size and averaged down: the
// anti-aliasing a real lens gives, so corners do not crawl from frame to frame.
constexpr int kSupersampling = 2;
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

// Splits the rectangle origin + a*u + b*v (a, b in [0, 1]) into n_u x n_v panels.
void addPanels(const Vec3& origin, const Vec3& u, const Vec3& v, int n_u, int n_v, std::vector<Panel>& panels) {
  for (int i = 0; i < n_u; ++i)
    for (int j = 0; j < n_v; ++j) {
      const Vec3 a = origin + u * (static_cast<double>(i) / n_u) + v * (static_cast<double>(j) / n_v);
      const Vec3 du = u / n_u, dv = v / n_v;
      panels.push_back({{a, a + du, a + du + dv, a + dv}, 0});
    }
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
  return camera;
}

std::vector<StampedPose> roomLoopPath(const RoomLoopParams& params) {
  std::vector<StampedPose> path;
  const double total_angle = 2.0 * M_PI * params.turns;
  for (int k = 0; k < params.frames; ++k) {
    const double angle = params.frames > 1 ? total_angle * k / (params.frames - 1) : 0.0;
    const Vec3 outward(std::cos(angle), 0.0, std::sin(angle));
    const Vec3 centre = params.path_radius_m * outward + Vec3(0.0, params.bob_m * std::sin(2.0 * angle), 0.0);
    // Camera axes in the world: z looks outwards, y is down, x = y cross z.
    Mat3 R_wc;
    R_wc.col(2) = outward;
    R_wc.col(1) = Vec3(0.0, 1.0, 0.0);
    R_wc.col(0) = R_wc.col(1).cross(R_wc.col(2));
    path.push_back({params.start_time_s + k / params.camera.fps, SE3(R_wc, centre)});
  }
  return path;
}

struct RoomLoopRenderer::Scene {
  RoomLoopParams params;
  OsmesaContext context;
  std::vector<Panel> panels;

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
  for (Panel& panel : panels) {
    cv::Mat rgb;
    cv::cvtColor(drawPanelTexture(params.texture_px, rng), rgb, cv::COLOR_BGR2RGB);
    glGenTextures(1, &panel.texture);
    glBindTexture(GL_TEXTURE_2D, panel.texture);
    glTexParameteri(GL_TEXTURE_2D, GL_GENERATE_MIPMAP, GL_TRUE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB, rgb.cols, rgb.rows, 0, GL_RGB, GL_UNSIGNED_BYTE, rgb.data);
  }
  if (glGetError() != GL_NO_ERROR) throw std::runtime_error("RoomLoopRenderer: OpenGL refused the panel textures");
}

RoomLoopRenderer::~RoomLoopRenderer() {
  scene_->context.makeCurrent();
  for (Panel& panel : scene_->panels) glDeleteTextures(1, &panel.texture);
}

cv::Mat RoomLoopRenderer::render(const SE3& T_wc) {
  OsmesaContext& context = scene_->context;
  context.makeCurrent();
  const PinholeCamera& camera = scene_->params.camera;
  const double s = kSupersampling;
  const double width = camera.width * s, height = camera.height * s;
  // Intrinsics at the drawn size. A pixel's centre is at window coordinate i + 0.5,
  // and at pixel coordinate (i + 0.5) / s - 0.5 once averaged down.
  const double fx = camera.fx * s, fy = camera.fy * s;
  const double cx = (camera.cx + 0.5) * s, cy = (camera.cy + 0.5) * s;
  glViewport(0, 0, static_cast<GLsizei>(width), static_cast<GLsizei>(height));
  glClearColor(0.f, 0.f, 0.f, 1.f);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDisable(GL_LIGHTING);
  glDisable(GL_CULL_FACE);

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

  glEnable(GL_TEXTURE_2D);
  glTexEnvi(GL_TEXTURE_ENV, GL_TEXTURE_ENV_MODE, GL_REPLACE);
  constexpr std::array<std::array<float, 2>, 4> kTexCoords = {{{0.f, 0.f}, {1.f, 0.f}, {1.f, 1.f}, {0.f, 1.f}}};
  for (const Panel& panel : scene_->panels) {
    glBindTexture(GL_TEXTURE_2D, panel.texture);
    glBegin(GL_QUADS);
    for (int c = 0; c < 4; ++c) {
      glTexCoord2f(kTexCoords[c][0], kTexCoords[c][1]);
      glVertex3d(panel.corners[c].x(), panel.corners[c].y(), panel.corners[c].z());
    }
    glEnd();
  }
  glDisable(GL_TEXTURE_2D);

  cv::Mat drawn = context.readPixels();
  cv::Mat image;
  cv::resize(drawn, image, cv::Size(camera.width, camera.height), 0, 0, cv::INTER_AREA);
  return image;
}

void writeRoomLoopSequence(const RoomLoopParams& params, const std::string& folder,
                           const std::function<void(int, int)>& progress) {
  namespace fs = std::filesystem;
  const fs::path root(folder);
  fs::create_directories(root / "rgb");
  const std::vector<StampedPose> path = roomLoopPath(params);
  RoomLoopRenderer renderer(params);

  std::ofstream list(root / "rgb.txt");
  if (!list) throw std::runtime_error("cannot write " + (root / "rgb.txt").string());
  list << "# synthetic room loop: " << params.frames << " frames, " << params.turns << " turns, seed " << params.seed
       << "\n# timestamp filename\n";
  for (size_t k = 0; k < path.size(); ++k) {
    char stamp[32];
    std::snprintf(stamp, sizeof stamp, "%.6f", path[k].timestamp);
    const std::string name = std::string("rgb/") + stamp + ".png";
    if (!cv::imwrite((root / name).string(), renderer.render(path[k].T_wc)))
      throw std::runtime_error("cannot write " + (root / name).string());
    list << stamp << " " << name << "\n";
    if (progress) progress(static_cast<int>(k + 1), static_cast<int>(path.size()));
  }
  list.close();
  if (!list) throw std::runtime_error("cannot write " + (root / "rgb.txt").string());
  writeTumTrajectory((root / "groundtruth.txt").string(), path);

  const PinholeCamera& c = params.camera;
  std::ofstream yaml(root / "camera.yaml");
  yaml.precision(10);
  yaml << "# The synthetic room's pinhole camera (no distortion).\ncamera:\n"
       << "  name: " << c.name << "\n  width: " << c.width << "\n  height: " << c.height << "\n  fx: " << c.fx
       << "\n  fy: " << c.fy << "\n  cx: " << c.cx << "\n  cy: " << c.cy << "\n  fps: " << c.fps << "\n";
  if (!yaml) throw std::runtime_error("cannot write " + (root / "camera.yaml").string());
}

}  // namespace vslam
