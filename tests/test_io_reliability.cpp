// The io pieces behind docs/RELIABILITY.md: outputs that appear whole or not at
// all, write errors (a full disk) that are reported, and truncated images,
// which OpenCV would decode into partial frames without a word.
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "test_support.hpp"
#include "vslam/core/error.hpp"
#include "vslam/io/atomic_file.hpp"
#include "vslam/io/image_files.hpp"
#include "vslam/io/ply.hpp"
#include "vslam/io/trajectory_io.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::vector<std::string> folderListing(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

TEST(AtomicFile, WritesThroughATemporaryNameAndRenames) {
  const fs::path dir = test::scratchDir("io_atomic_write");
  const fs::path path = dir / "report.json";
  std::string seen_temporary;
  writeFileAtomically(path.string(), [&](const std::string& temporary) {
    seen_temporary = temporary;
    std::ofstream(temporary) << "new";
    EXPECT_FALSE(fs::exists(path));  // nothing under the final name while it is being written
  });
  EXPECT_EQ(seen_temporary, (dir / ".report.json.partial").string());
  EXPECT_EQ(slurp(path), "new");
  EXPECT_EQ(folderListing(dir), std::vector<std::string>{"report.json"});
}

TEST(AtomicFile, AFailedWriteLeavesThePreviousFileAndNoTemporary) {
  const fs::path dir = test::scratchDir("io_atomic_fail");
  const fs::path path = dir / "trajectory.txt";
  std::ofstream(path) << "old";
  EXPECT_THROW(writeFileAtomically(path.string(),
                                   [](const std::string& temporary) {
                                     std::ofstream(temporary) << "half";
                                     throw InputError(temporary, 0, "write error");
                                   }),
               InputError);
  EXPECT_EQ(slurp(path), "old");
  EXPECT_EQ(folderListing(dir), std::vector<std::string>{"trajectory.txt"});

  // The final name is a folder: the rename fails, naming the file.
  const fs::path folder = dir / "map.ply";
  fs::create_directories(folder);
  try {
    writeFileAtomically(folder.string(), [](const std::string& temporary) { std::ofstream(temporary) << "x"; });
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(folder.string() + ": cannot write the file: ", 0), 0u) << e.what();
  }
  EXPECT_EQ(folderListing(dir), (std::vector<std::string>{"map.ply", "trajectory.txt"}));
}

// /dev/full fails every write with ENOSPC, as a full disk does.
TEST(WriteErrors, AFullDiskIsAnErrorNamingTheFile) {
  ASSERT_TRUE(fs::exists("/dev/full"));
  std::vector<StampedPose> poses(1000);
  try {
    writeTumTrajectory("/dev/full", poses);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "/dev/full: write error");
  }
  std::vector<PlyPoint> points(1000);
  EXPECT_THROW(writeMapPly("/dev/full", points), std::runtime_error);
}

TEST(ImageTruncation, WholeImagesPassAndCutOnesAreNamed) {
  const fs::path dir = test::scratchDir("io_image_truncation");
  const cv::Mat image(48, 64, CV_8UC3, cv::Scalar(10, 200, 30));
  const fs::path jpeg = dir / "a.jpg", png = dir / "b.png", bmp = dir / "c.bmp";
  ASSERT_TRUE(cv::imwrite(jpeg.string(), image));
  ASSERT_TRUE(cv::imwrite(png.string(), image));
  ASSERT_TRUE(cv::imwrite(bmp.string(), image));
  EXPECT_EQ(imageTruncation(jpeg), "");
  EXPECT_EQ(imageTruncation(png), "");
  EXPECT_EQ(imageTruncation(bmp), "");  // no end marker to check: not judged
  // A real JPEG of the shared data, whole.
  EXPECT_EQ(imageTruncation(test::tumSequence("freiburg1_xyz") / "rgb" / "1305031102.175304.jpg"), "");

  // Cut by 3 bytes: OpenCV still decodes both, the check does not let them through.
  for (const fs::path& path : {jpeg, png}) fs::resize_file(path, fs::file_size(path) - 3);
  EXPECT_FALSE(cv::imread(jpeg.string()).empty());
  EXPECT_EQ(imageTruncation(jpeg), "truncated JPEG: no end-of-image marker (FF D9) at its end");
  EXPECT_EQ(imageTruncation(png), "truncated PNG: no IEND chunk at its end");
  // A few padding bytes after the end marker are allowed.
  ASSERT_TRUE(cv::imwrite(jpeg.string(), image));
  std::ofstream(jpeg, std::ios::app | std::ios::binary) << std::string(4, '\0');
  EXPECT_EQ(imageTruncation(jpeg), "");
}

}  // namespace
}  // namespace vslam
