#include <cmath>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "test_support.hpp"
#include "vslam/render/map_render.hpp"

namespace vslam {
namespace {

cv::Vec3b toVec3b(const cv::Scalar& s) {
  return cv::Vec3b(static_cast<uchar>(s[0]), static_cast<uchar>(s[1]), static_cast<uchar>(s[2]));
}

int colourDistance(const cv::Vec3b& a, const cv::Vec3b& b) {
  return std::abs(a[0] - b[0]) + std::abs(a[1] - b[1]) + std::abs(a[2] - b[2]);
}

cv::Vec3b pixelAt(const cv::Mat& image, const cv::Point2d& p) {
  return image.at<cv::Vec3b>(static_cast<int>(std::lround(p.y)), static_cast<int>(std::lround(p.x)));
}

constexpr int kClusterClass = 2;  // car
constexpr int kBoxClass = 56;     // chair
const Vec3 kClusterCentre(1.5, 1.5, 0.5);
const cv::Vec3b kClusterImageColour(10, 200, 30);

// A 2 m x 2 m floor of unlabelled points at z = 0, a small cluster of class
// kClusterClass floating above it, a box of class kBoxClass elsewhere, two
// keyframes and a trajectory.
MapRenderInput knownScene() {
  MapRenderInput input;
  input.title = "known scene";
  for (int i = 0; i <= 40; ++i)
    for (int j = 0; j <= 40; ++j) input.points.push_back({Vec3(0.05 * i, 0.05 * j, 0.0), cv::Vec3b(120, 120, 120), -1});
  for (int i = -2; i <= 2; ++i)
    for (int j = -2; j <= 2; ++j)
      for (int k = -2; k <= 2; ++k)
        input.points.push_back({kClusterCentre + 0.01 * Vec3(i, j, k), kClusterImageColour, kClusterClass});
  input.objects.push_back({"chair", kBoxClass, Vec3(0.2, 0.2, 0.0), Vec3(0.6, 0.5, 0.3)});
  input.keyframes.push_back({SE3(Mat3::Identity(), Vec3(1.0, 0.0, 1.0))});
  input.keyframes.push_back({SE3(Mat3::Identity(), Vec3(1.5, 0.0, 1.0))});
  input.trajectory = {Vec3(1.0, 0.0, 1.0), Vec3(1.5, 0.0, 1.0)};
  return input;
}

TEST(RenderMap, LabelledClusterHasItsClassColour) {
  const MapRenderInput input = knownScene();
  for (PlotView view : {PlotView::Top, PlotView::Perspective}) {
    PlotProjection projection;
    const cv::Mat image = renderMap(input, MapColouring::ObjectClass, view, {1280, 960}, &projection);
    EXPECT_LE(colourDistance(pixelAt(image, projection.toPixel(kClusterCentre)), toVec3b(classColour(kClusterClass))), 6)
        << "view " << static_cast<int>(view);
    // An unlabelled floor point, away from everything else, is small and light
    // grey: its darkest pixel is close to that grey, not to a class colour.
    const cv::Point2d floor_point = projection.toPixel(Vec3(1.8, 0.9, 0.0));
    int nearest_to_grey = 1000;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx)
        nearest_to_grey = std::min(nearest_to_grey, colourDistance(pixelAt(image, floor_point + cv::Point2d(dx, dy)),
                                                                   toVec3b(classColour(-1))));
    EXPECT_LE(nearest_to_grey, 12) << "view " << static_cast<int>(view);
    cv::imwrite(std::string(VSLAM_BINARY_DIR) + "/test_scratch/known_scene_" + std::to_string(static_cast<int>(view)) + ".png", image);
    // Between the floor points: page white (or a light grid line).
    const cv::Vec3b empty = pixelAt(image, projection.toPixel(Vec3(1.025, 1.025, 0.0)));
    EXPECT_GE(std::min({empty[0], empty[1], empty[2]}), 200) << empty << " view " << static_cast<int>(view);
  }
}

TEST(RenderMap, ImageColouringUsesThePointColour) {
  PlotProjection projection;
  const cv::Mat image = renderMap(knownScene(), MapColouring::ImageColour, PlotView::Top, {1280, 960}, &projection);
  EXPECT_LE(colourDistance(pixelAt(image, projection.toPixel(kClusterCentre)), kClusterImageColour), 6);
}

TEST(RenderMap, ObjectBoxEdgesHaveTheClassColour) {
  const MapRenderInput input = knownScene();
  for (PlotView view : {PlotView::Top, PlotView::Perspective}) {
    PlotProjection projection;
    const cv::Mat image = renderMap(input, MapColouring::ObjectClass, view, {1280, 960}, &projection);
    // Middle of the box's top edge nearest the -y side (the label sits at the top of the image instead).
    const cv::Point2d edge = projection.toPixel(Vec3(0.4, 0.2, 0.3));
    EXPECT_LE(colourDistance(pixelAt(image, edge), toVec3b(classColour(kBoxClass))), 6) << "view " << static_cast<int>(view);
    // Inside the box, seen from above, is floor, not edge colour.
    const cv::Point2d inside = projection.toPixel(Vec3(0.42, 0.36, 0.3));
    EXPECT_GT(colourDistance(pixelAt(image, inside), toVec3b(classColour(kBoxClass))), 60);
  }
}

TEST(RenderMap, ClassColoursAreDistinctAndDeterministic) {
  double min_distance = 1e9;
  for (int a = 0; a < 80; ++a) {
    EXPECT_EQ(classColour(a), classColour(a));
    EXPECT_GE(cv::norm(classColour(a) - classColour(-1)), 40.0) << a;
    for (int b = a + 1; b < 80; ++b) min_distance = std::min(min_distance, cv::norm(classColour(a) - classColour(b)));
  }
  EXPECT_GE(min_distance, 50.0);
  EXPECT_EQ(classColour(-1), cv::Scalar(200, 200, 200));
  EXPECT_EQ(cocoClassName(56), "chair");
  EXPECT_EQ(cocoClassId("chair"), 56);
  EXPECT_EQ(cocoClassId("unicorn"), -1);
}

TEST(RenderMap, RendersAreDeterministic) {
  const MapRenderInput input = knownScene();
  const cv::Mat first = renderMap(input, MapColouring::ObjectClass, PlotView::Perspective);
  const cv::Mat second = renderMap(input, MapColouring::ObjectClass, PlotView::Perspective);
  EXPECT_EQ(cv::norm(first, second, cv::NORM_INF), 0.0);
}

// A real-looking figure for the docs: fr1_xyz back-projected from four depth
// frames at their ground-truth poses, with points in one image region
// labelled as a "tvmonitor" object.
TEST(RenderMap, Fr1XyzFigures) {
  const auto sequence = test::tumSequence("freiburg1_xyz");
  std::ifstream gt_file(sequence / "groundtruth.txt");
  std::vector<std::pair<double, SE3>> poses;
  std::string line;
  while (std::getline(gt_file, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double t, x, y, z, qx, qy, qz, qw;
    fields >> t >> x >> y >> z >> qx >> qy >> qz >> qw;
    poses.push_back({t, SE3(Quat(qw, qx, qy, qz), Vec3(x, y, z))});
  }
  ASSERT_GT(poses.size(), 100u);
  auto poseAt = [&](double t) {
    auto best = poses.front();
    for (const auto& p : poses)
      if (std::abs(p.first - t) < std::abs(best.first - t)) best = p;
    return best.second;
  };
  std::ifstream rgb_list(sequence / "rgb.txt"), depth_list(sequence / "depth.txt");
  std::vector<std::pair<double, std::string>> rgbs, depths;
  for (auto* list : {&rgb_list, &depth_list})
    while (std::getline(*list, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream fields(line);
      double t;
      std::string path;
      fields >> t >> path;
      (list == &rgb_list ? rgbs : depths).push_back({t, path});
    }
  MapRenderInput input;
  input.title = "tum/fr1_xyz - ground-truth poses, depth back-projected (4 frames)";
  const double fx = 517.306408, fy = 516.469215, cx = 318.643040, cy = 255.313989;
  Vec3 box_min = Vec3::Constant(1e9), box_max = Vec3::Constant(-1e9);
  for (size_t frame : {0, 250, 500, 750}) {
    const cv::Mat rgb = cv::imread((sequence / rgbs[frame].second).string());
    const cv::Mat depth = cv::imread((sequence / depths[frame].second).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(rgb.empty());
    ASSERT_FALSE(depth.empty());
    const SE3 T_wc = poseAt(rgbs[frame].first);
    input.keyframes.push_back({T_wc});
    for (int v = 0; v < depth.rows; v += 6)
      for (int u = 0; u < depth.cols; u += 6) {
        const double z = depth.at<uint16_t>(v, u) / 5000.0;
        if (z <= 0.0 || z > 3.0) continue;
        const Vec3 p = T_wc * Vec3((u - cx) * z / fx, (v - cy) * z / fy, z);
        const bool on_object = frame == 0 && u > 250 && u < 420 && v > 60 && v < 200 && z < 1.5;
        input.points.push_back({p, rgb.at<cv::Vec3b>(v, u), on_object ? 62 : -1});
        if (on_object) {
          box_min = box_min.cwiseMin(p);
          box_max = box_max.cwiseMax(p);
        }
      }
  }
  input.objects.push_back({"tvmonitor 0.87", 62, box_min, box_max});
  for (size_t i = 0; i < poses.size(); i += 10) input.trajectory.push_back(poses[i].second.t);
  const auto dir = test::scratchDir("render_map_fr1_xyz");
  writeMapRenders(input, dir.string());
  for (const char* name : {"map_colour.png", "map_classes.png", "map_top.png"})
    EXPECT_EQ(cv::imread((dir / name).string()).size(), cv::Size(1280, 960)) << name;
}

}  // namespace
}  // namespace vslam
