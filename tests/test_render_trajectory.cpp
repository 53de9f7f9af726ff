#include <cmath>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "test_support.hpp"
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
