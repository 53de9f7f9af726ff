#include <cmath>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "test_support.hpp"
#include <GL/gl.h>

#include "vslam/render/osmesa_context.hpp"
#include "vslam/render/plot_canvas.hpp"
#include "vslam/render/trajectory_plot.hpp"

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

// fr1_xyz's ground truth with an estimate that drifts smoothly off it.
TrajectoryPlotInput fr1XyzExample() {
  std::ifstream file(test::tumSequence("freiburg1_xyz") / "groundtruth.txt");
  TrajectoryPlotInput input;
  input.title = "tum/fr1_xyz — mono — ATE RMSE 1.23 cm (synthetic estimate)";
  std::string line;
  int index = 0;
  while (std::getline(file, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double t, x, y, z;
    fields >> t >> x >> y >> z;
    input.groundtruth.emplace_back(x, y, z);
    if (index++ % 10 == 0) {
      const double s = index * 0.002;
      const Vec3 offset(0.02 * std::sin(s), 0.015 * std::cos(1.3 * s), 0.01 * std::sin(0.7 * s));
      input.estimate.push_back(input.groundtruth.back() + offset);
      input.error_m.push_back(offset.norm());
    }
  }
  return input;
}

// The estimate runs straight from (0,0,0) to (1,0,0); the ground truth runs
// parallel 10 cm off in +y, so the two are apart everywhere.
TrajectoryPlotInput straightLine() {
  TrajectoryPlotInput input;
  input.title = "straight line — test";
  for (int i = 0; i <= 10; ++i) {
    input.estimate.emplace_back(0.1 * i, 0.0, 0.0);
    input.groundtruth.emplace_back(0.1 * i, 0.1, 0.0);
  }
  return input;
}

bool isPageOrGrid(const cv::Vec3b& pixel) {
  return colourDistance(pixel, toVec3b(plot_colour::kBackground)) <= 3 ||
         colourDistance(pixel, toVec3b(plot_colour::kGrid)) <= 30;
}

// The dashes are 6 px long with 2 px gaps: some pixel within 4 px along the line has the colour.
bool dashedLinePassesNear(const cv::Mat& image, const cv::Point2d& where, const cv::Scalar& colour) {
  for (int dx = -4; dx <= 4; ++dx)
    if (colourDistance(pixelAt(image, where + cv::Point2d(dx, 0)), toVec3b(colour)) <= 12) return true;
  return false;
}

TEST(RenderTrajectory, TopViewStraightLineLandsWhereProjected) {
  PlotProjection projection;
  const cv::Mat image = renderTrajectoryPlot(straightLine(), PlotView::Top, {1280, 960}, &projection);
  ASSERT_EQ(image.size(), cv::Size(1280, 960));
  // x-y is the plane with the largest spread; x to the right, y up.
  EXPECT_EQ(projection.plane.right, 0);
  EXPECT_EQ(projection.plane.up_in_image, 1);
  EXPECT_LT(projection.toPixel(Vec3(0, 0.1, 0)).y, projection.toPixel(Vec3::Zero()).y);
  for (double x = 0.15; x < 0.96; x += 0.1) {
    const cv::Point2d on_estimate = projection.toPixel(Vec3(x, 0.0, 0.0));
    EXPECT_LE(colourDistance(pixelAt(image, on_estimate), toVec3b(kEstimateColour)), 6) << "x = " << x;
    EXPECT_TRUE(dashedLinePassesNear(image, projection.toPixel(Vec3(x, 0.1, 0.0)), plot_colour::kGroundTruth))
        << "x = " << x;
    // Between and beside the two paths: nothing drawn.
    EXPECT_TRUE(isPageOrGrid(pixelAt(image, projection.toPixel(Vec3(x, 0.05, 0.0))))) << "x = " << x;
    EXPECT_TRUE(isPageOrGrid(pixelAt(image, projection.toPixel(Vec3(x, -0.05, 0.0))))) << "x = " << x;
  }
}

TEST(RenderTrajectory, TopViewGridIsDrawnWhereverTheSceneIs) {
  // Far from the origin along the viewing axis: the grid must still be inside the clip volume.
  TrajectoryPlotInput input = straightLine();
  for (auto* path : {&input.estimate, &input.groundtruth})
    for (Vec3& p : *path) p.z() += 40.0;
  PlotProjection projection;
  const cv::Mat image = renderTrajectoryPlot(input, PlotView::Top, {1280, 960}, &projection);
  double low_right, high_right, low_up, high_up;
  topViewWorldRange(projection, plotArea(image.size(), PlotMargins{}), low_right, high_right, low_up, high_up);
  const double step = niceTickStep(std::max(high_right - low_right, high_up - low_up), 8);
  const double grid_x = ticksIn(0.12, 0.9, step).at(0);
  const cv::Point2d on_grid = projection.toPixel(Vec3(grid_x, -0.13, 40.0));
  int nearest = 1000;
  for (int dx = -1; dx <= 1; ++dx)
    nearest = std::min(nearest, colourDistance(pixelAt(image, on_grid + cv::Point2d(dx, 0)), toVec3b(plot_colour::kGrid)));
  EXPECT_LE(nearest, 6) << "grid line x = " << grid_x;
}

TEST(RenderTrajectory, EstimateIsColouredByItsError) {
  TrajectoryPlotInput input = straightLine();
  for (int i = 0; i <= 10; ++i) input.error_m.push_back(0.002 * i);  // 0 .. 2 cm
  PlotProjection projection;
  const cv::Mat image = renderTrajectoryPlot(input, PlotView::Top, {1280, 960}, &projection);
  // Segment i (from vertex i-1 to i) has the colour of vertex i's error.
  for (int i = 2; i <= 10; i += 2) {
    const cv::Point2d middle = projection.toPixel(Vec3(0.1 * i - 0.05, 0.0, 0.0));
    EXPECT_LE(colourDistance(pixelAt(image, middle), toVec3b(viridisColour(i / 10.0))), 6) << "segment " << i;
  }
  EXPECT_GT(colourDistance(toVec3b(viridisColour(0.2)), toVec3b(viridisColour(1.0))), 100);
}

TEST(RenderTrajectory, PerspectiveViewProjectsThePaths) {
  PlotProjection projection;
  const cv::Mat image = renderTrajectoryPlot(straightLine(), PlotView::Perspective, {1280, 960}, &projection);
  for (double x : {0.35, 0.55, 0.75}) {
    ASSERT_TRUE(projection.inFront(Vec3(x, 0, 0)));
    EXPECT_LE(colourDistance(pixelAt(image, projection.toPixel(Vec3(x, 0.0, 0.0))), toVec3b(kEstimateColour)), 6);
  }
  // The projection keeps the whole scene inside the image.
  for (const Vec3& corner : {Vec3(0, 0, 0), Vec3(1, 0.1, 0)}) {
    const cv::Point2d px = projection.toPixel(corner);
    EXPECT_TRUE(px.x > 0 && px.y > 0 && px.x < 1280 && px.y < 960) << px;
  }
}

TEST(RenderTrajectory, RendersAreDeterministic) {
  TrajectoryPlotInput input = straightLine();
  for (int i = 0; i <= 10; ++i) input.error_m.push_back(0.001 * i);
  for (PlotView view : {PlotView::Top, PlotView::Perspective}) {
    const cv::Mat first = renderTrajectoryPlot(input, view);
    const cv::Mat second = renderTrajectoryPlot(input, view);
    EXPECT_EQ(cv::norm(first, second, cv::NORM_INF), 0.0);
  }
}

TEST(RenderTrajectory, EmptyInputStillRenders) {
  const cv::Mat image = renderTrajectoryPlot({}, PlotView::Perspective, {640, 480});
  EXPECT_EQ(image.size(), cv::Size(640, 480));
}

TEST(OsmesaContext, TwoContextsInOneProcess) {
  for (const auto& [size, red] : {std::pair{cv::Size(64, 48), 1.0f}, std::pair{cv::Size(32, 16), 0.0f}}) {
    OsmesaContext context(size.width, size.height);
    glClearColor(red, 0.0f, 1.0f - red, 1.0f);
    glClear(GL_COLOR_BUFFER_BIT);
    const cv::Mat pixels = context.readPixels();
    ASSERT_EQ(pixels.size(), size);
    EXPECT_EQ(pixels.at<cv::Vec3b>(size.height - 1, 0), cv::Vec3b(red ? 0 : 255, 0, red ? 255 : 0));
  }
  // Two alive at once, switching between them.
  OsmesaContext first(8, 8), second(8, 8);
  first.makeCurrent();
  glClearColor(0, 1, 0, 1);
  glClear(GL_COLOR_BUFFER_BIT);
  second.makeCurrent();
  glClearColor(1, 1, 1, 1);
  glClear(GL_COLOR_BUFFER_BIT);
  EXPECT_EQ(first.readPixels().at<cv::Vec3b>(0, 0), cv::Vec3b(0, 255, 0));
  EXPECT_EQ(second.readPixels().at<cv::Vec3b>(0, 0), cv::Vec3b(255, 255, 255));
}

TEST(OsmesaContext, ReadPixelsIsTopDown) {
  OsmesaContext context(10, 10);
  glClearColor(0, 0, 0, 1);
  glClear(GL_COLOR_BUFFER_BIT);
  glEnable(GL_SCISSOR_TEST);
  glScissor(0, 0, 10, 1);  // GL's bottom row
  glClearColor(1, 1, 1, 1);
  glClear(GL_COLOR_BUFFER_BIT);
  glDisable(GL_SCISSOR_TEST);
  const cv::Mat pixels = context.readPixels();
  EXPECT_EQ(pixels.at<cv::Vec3b>(9, 5), cv::Vec3b(255, 255, 255));
  EXPECT_EQ(pixels.at<cv::Vec3b>(0, 5), cv::Vec3b(0, 0, 0));
}

TEST(PlotAxes, NiceTickSteps) {
  EXPECT_DOUBLE_EQ(niceTickStep(1.0, 5), 0.2);
  EXPECT_DOUBLE_EQ(niceTickStep(0.47, 6), 0.1);
  EXPECT_DOUBLE_EQ(niceTickStep(7.0, 7), 1.0);
  EXPECT_DOUBLE_EQ(niceTickStep(15.0, 6), 2.0);
  EXPECT_DOUBLE_EQ(niceTickStep(300.0, 6), 50.0);
  EXPECT_NEAR(niceTickStep(0.0032, 4), 0.001, 1e-12);
  EXPECT_DOUBLE_EQ(niceTickStep(0.0, 5), 1.0);
  for (double range : {0.013, 0.77, 4.2, 56.0, 910.0}) {
    const double step = niceTickStep(range, 6);
    const double mantissa = step / std::pow(10.0, std::floor(std::log10(step) + 1e-9));
    EXPECT_TRUE(std::abs(mantissa - 1) < 1e-9 || std::abs(mantissa - 2) < 1e-9 || std::abs(mantissa - 5) < 1e-9)
        << range << " -> " << step;
    EXPECT_GE(range / step, 3.0);
    EXPECT_LE(range / step, 12.0);
  }
}

TEST(PlotAxes, ScaleBarLengthIsNiceAndFits) {
  EXPECT_DOUBLE_EQ(niceLengthAtMost(0.37), 0.2);
  EXPECT_DOUBLE_EQ(niceLengthAtMost(1.0), 1.0);
  EXPECT_DOUBLE_EQ(niceLengthAtMost(0.099), 0.05);
  EXPECT_DOUBLE_EQ(niceLengthAtMost(5.0), 5.0);
  EXPECT_DOUBLE_EQ(niceLengthAtMost(49.0), 20.0);
  EXPECT_DOUBLE_EQ(niceLengthAtMost(0.0), 0.0);
  EXPECT_EQ(formatLength(0.1), "10 cm");
  EXPECT_EQ(formatLength(2.0), "2 m");
  EXPECT_EQ(formatLength(0.005), "5 mm");
  EXPECT_EQ(formatLength(5000.0), "5 km");
}

TEST(PlotAxes, TicksAndLabels) {
  const std::vector<double> ticks = ticksIn(-0.25, 0.5, 0.1);
  ASSERT_EQ(ticks.size(), 8u);
  EXPECT_NEAR(ticks.front(), -0.2, 1e-12);
  EXPECT_NEAR(ticks.back(), 0.5, 1e-12);
  EXPECT_EQ(formatTick(0.3, 0.1), "0.3");
  EXPECT_EQ(formatTick(-1e-17, 0.1), "0.0");
  EXPECT_EQ(formatTick(2.0, 1.0), "2");
  EXPECT_EQ(formatTick(0.05, 0.05), "0.05");
  EXPECT_EQ(toHersheyText("fr1 — mono – 3°"), "fr1 - mono - 3 deg");
}

TEST(PlotAxes, TopPlaneDropsTheFlattestAxis) {
  // A KITTI-like drive: x and z spread, y (down) nearly constant -> x right, z up, seen from -y (above).
  const TopPlane road = chooseTopPlane({Vec3(0, 0, 0), Vec3(50, 1.5, 200), Vec3(-30, 0.5, 100)});
  EXPECT_EQ(road.right, 0);
  EXPECT_EQ(road.up_in_image, 2);
  EXPECT_EQ(road.toward_viewer, Vec3(0, -1, 0));
  const TopPlane wall = chooseTopPlane({Vec3(0, 0, 0), Vec3(0.1, 2, 3)});
  EXPECT_EQ(wall.right, 1);
  EXPECT_EQ(wall.up_in_image, 2);
  EXPECT_EQ(wall.toward_viewer, Vec3(1, 0, 0));
}

TEST(RenderTrajectory, Fr1XyzFigures) {
  const TrajectoryPlotInput input = fr1XyzExample();
  ASSERT_GT(input.groundtruth.size(), 1000u);
  const auto dir = test::scratchDir("render_trajectory_fr1_xyz");
  writeTrajectoryPlots(input, dir.string());
  for (const char* name : {"trajectory_top.png", "trajectory_3d.png"}) {
    const cv::Mat image = cv::imread((dir / name).string());
    ASSERT_EQ(image.size(), cv::Size(1280, 960)) << name;
  }
}

}  // namespace
}  // namespace vslam
