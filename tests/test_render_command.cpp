// `vslam render RUN_DIR` end to end on a synthetic run folder: a monocular
// estimate that is the ground truth under a known similarity, a map with a
// labelled cluster, one object box, keyframes and a report.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "log_capture.hpp"
#include "test_support.hpp"
#include "vslam/io/ply.hpp"
#include "vslam/render/map_render.hpp"
#include "vslam/render/plot_canvas.hpp"
#include "vslam/render/run_renders.hpp"
#include "vslam/render/trajectory_plot.hpp"

namespace vslam {
namespace {

// The estimate is the ground truth seen through this similarity (a monocular
// run's arbitrary frame and scale); the renders align it back.
Sim3 slamFromWorld() {
  return Sim3(0.5, Eigen::AngleAxisd(M_PI / 6, Vec3::UnitZ()).toRotationMatrix(), Vec3(1, 2, 3));
}

namespace fs = std::filesystem;

int colourDistance(const cv::Vec3b& a, const cv::Scalar& b) {
  return std::abs(a[0] - static_cast<int>(b[0])) + std::abs(a[1] - static_cast<int>(b[1])) +
         std::abs(a[2] - static_cast<int>(b[2]));
}

cv::Vec3b pixelAt(const cv::Mat& image, const cv::Point2d& p) {
  return image.at<cv::Vec3b>(static_cast<int>(std::lround(p.y)), static_cast<int>(std::lround(p.x)));
}

Vec3 groundTruthAt(int i) { return Vec3(0.05 * i, 0.4 * std::sin(0.1 * i), 0.01 * std::cos(0.2 * i)); }

constexpr int kPoses = 40;
constexpr int kBoxClass = 41;  // cup

struct RunFolder {
  fs::path dir;
  std::vector<Vec3> groundtruth;
  std::vector<Vec3> estimate;  // in the SLAM frame, as trajectory.txt holds it
  Vec3 box_min, box_max;
};

RunFolder writeRunFolder(const std::string& scratch_name) {
  RunFolder run;
  run.dir = test::scratchDir(scratch_name) / "run";
  fs::create_directories(run.dir);
  // The SLAM frame: scale 0.5, 30° about z, shifted; timestamps 5 ms off the ground truth's.
  const Sim3 slam_from_world = slamFromWorld();
  std::ofstream groundtruth(run.dir / "gt.txt"), trajectory(run.dir / "trajectory.txt"),
      keyframes(run.dir / "keyframes.txt");
  for (std::ofstream* file : {&groundtruth, &trajectory, &keyframes}) *file << std::setprecision(12);
  groundtruth << "# timestamp tx ty tz qx qy qz qw\n";
  Vec3 low = Vec3::Constant(1e9), high = Vec3::Constant(-1e9);
  for (int i = 0; i < kPoses; ++i) {
    const Vec3 p = groundTruthAt(i);
    run.groundtruth.push_back(p);
    const Vec3 q = slam_from_world * p;
    run.estimate.push_back(q);
    low = low.cwiseMin(q);
    high = high.cwiseMax(q);
    groundtruth << 100.0 + 0.1 * i << " " << p.x() << " " << p.y() << " " << p.z() << " 0 0 0 1\n";
    trajectory << 100.005 + 0.1 * i << " " << q.x() << " " << q.y() << " " << q.z() << " 0 0 0 1\n";
    if (i % 10 == 0) keyframes << 100.005 + 0.1 * i << " " << q.x() << " " << q.y() << " " << q.z() << " 0 0 0 1\n";
  }
  // The object box encloses everything else, so a top view of the map is the
  // top view fitted to the box alone.
  run.box_min = low - Vec3(0.3, 0.3, 0.05);
  run.box_max = high + Vec3(0.3, 0.3, 0.05);
  std::vector<PlyPoint> points;
  for (int i = 0; i < 50; ++i)
    points.push_back({low + (high - low).cwiseProduct(Vec3(0.02 * i, 0.5, 0.5)), cv::Vec3b(90, 90, 90), -1});
  for (int i = 0; i < 27; ++i)
    points.push_back({0.5 * (low + high) + 0.01 * Vec3(i % 3, (i / 3) % 3, i / 9), cv::Vec3b(0, 0, 250), kBoxClass});
  writeMapPly((run.dir / "map.ply").string(), points);
  std::ofstream(run.dir / "objects.json")
      << "[{\"class\": \"cup\", \"confidence\": 0.8, \"centroid\": [0, 0, 0], \"box_min\": [" << run.box_min.x() << ", "
      << run.box_min.y() << ", " << run.box_min.z() << "], \"box_max\": [" << run.box_max.x() << ", "
      << run.box_max.y() << ", " << run.box_max.z() << "], \"points\": 27, \"keyframes\": [0, 1]}]\n";
  std::ofstream(run.dir / "report.json")
      << R"({"sequence": "synthetic/line", "mode": "mono", "ate": {"rmse": 0.0}, "groundtruth_file": "gt.txt"})";
  return run;
}

TEST(RenderCommand, WritesFiguresOfARunFolder) {
  const RunFolder run = writeRunFolder("render_command");
  const fs::path out = run.dir.parent_path() / "figures";
  const std::string command = std::string(VSLAM_BINARY_DIR) + "/vslam render " + run.dir.string() + " --out " +
                              out.string() + " > " + (run.dir.parent_path() / "stdout.txt").string();
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  for (const char* name :
       {"trajectory_top.png", "trajectory_3d.png", "map_colour.png", "map_classes.png", "map_top.png"})
    ASSERT_TRUE(fs::exists(out / name)) << name;

  // After the Sim(3) alignment the estimate lies on the ground truth with no
  // error, so the top view is the one fitted to the ground truth and the
  // path there has the colour of zero error.
  const cv::Mat trajectory = cv::imread((out / "trajectory_top.png").string());
  const PlotProjection top = fitTopView(run.groundtruth, trajectory.size());
  for (int i : {12, 21, 33}) {
    const cv::Point2d middle = top.toPixel(0.5 * (groundTruthAt(i) + groundTruthAt(i + 1)));
    EXPECT_LE(colourDistance(pixelAt(trajectory, middle), viridisColour(0.0)), 8) << "segment " << i;
  }

  // The map's top view: the box's bottom edge (in the image) has the cup's colour.
  const cv::Mat map = cv::imread((out / "map_top.png").string());
  // The map is drawn aligned to the ground truth: the box becomes the
  // axis-aligned box of its corners taken back through the similarity.
  const Sim3 world_from_slam = slamFromWorld().inverse();
  Vec3 low = Vec3::Constant(1e9), high = Vec3::Constant(-1e9);
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3 p(corner & 1 ? run.box_max.x() : run.box_min.x(), corner & 2 ? run.box_max.y() : run.box_min.y(),
                 corner & 4 ? run.box_max.z() : run.box_min.z());
    low = low.cwiseMin(world_from_slam * p);
    high = high.cwiseMax(world_from_slam * p);
  }
  const PlotProjection map_top = fitTopView({low, high}, map.size());
  const Vec3 edge_middle(0.5 * (low.x() + high.x()), low.y(), high.z());
  EXPECT_LE(colourDistance(pixelAt(map, map_top.toPixel(edge_middle)), classColour(kBoxClass)), 6);
}

TEST(RenderCommand, UnreadableGroundTruthOnlyCostsTheComparison) {
  const RunFolder run = writeRunFolder("render_command_kitti_gt");
  std::ofstream(run.dir / "gt.txt") << "1 0 0 0 0 1 0 0 0 0 1 0\n";  // a KITTI pose line
  std::ofstream(run.dir / "report.json") << R"({"sequence": "s", "mode": "mono", "groundtruth_file": "gt.txt"})";
  const auto written = renderRunFolder(run.dir.string(), run.dir.string());
  ASSERT_EQ(written.size(), 5u);
  // The estimate alone, in its own frame and single colour.
  const cv::Mat image = cv::imread((run.dir / "trajectory_top.png").string());
  const PlotProjection top = fitTopView(run.estimate, image.size());
  const cv::Point2d middle = top.toPixel(0.5 * (run.estimate[20] + run.estimate[21]));
  EXPECT_LE(colourDistance(pixelAt(image, middle), kEstimateColour), 6);
}

// A run that never started a map writes its files with headers only: the
// render says they hold nothing, not that they are missing.
TEST(RenderCommand, RunWithoutPosesSaysItsFilesAreEmptyNotMissing) {
  const fs::path dir = test::scratchDir("render_command_empty") / "run";
  fs::create_directories(dir);
  std::ofstream(dir / "trajectory.txt") << "# timestamp tx ty tz qx qy qz qw\n";
  std::ofstream(dir / "keyframes.txt") << "# timestamp tx ty tz qx qy qz qw\n";
  writeMapPly((dir / "map.ply").string(), {});
  std::ofstream(dir / "objects.json") << "[]\n";
  std::ofstream(dir / "report.json") << R"({"sequence": "s", "mode": "mono", "groundtruth_file": null})";
  std::string log;
  {
    const test::CapturedLog captured;
    EXPECT_TRUE(renderRunFolder(dir.string(), dir.string()).empty());
    log = captured.text();
  }
  EXPECT_EQ(log.find("no trajectory.txt"), std::string::npos) << log;
  EXPECT_NE(log.find("trajectory.txt in " + dir.string() + " holds no poses"), std::string::npos) << log;
  EXPECT_EQ(log.find("no map.ply"), std::string::npos) << log;
  EXPECT_NE(log.find("map.ply, keyframes.txt, objects.json in " + dir.string() + ": no points, keyframes or objects"),
            std::string::npos)
      << log;
}

TEST(RenderCommand, MissingRunFolderFailsWithItsName) {
  const fs::path stderr_file = test::scratchDir("render_command_missing") / "stderr.txt";
  const std::string command =
      std::string(VSLAM_BINARY_DIR) + "/vslam render /nonexistent/run 2> " + stderr_file.string();
  EXPECT_NE(std::system(command.c_str()), 0);
  std::ifstream err(stderr_file);
  const std::string message((std::istreambuf_iterator<char>(err)), std::istreambuf_iterator<char>());
  EXPECT_NE(message.find("/nonexistent/run"), std::string::npos) << message;
}

}  // namespace
}  // namespace vslam
