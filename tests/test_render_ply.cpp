#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "test_support.hpp"
#include "vslam/core/error.hpp"
#include "vslam/io/ply.hpp"

namespace vslam {
namespace {

std::string errorOf(const std::string& path) {
  try {
    readMapPly(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Ply, BinaryRoundTrip) {
  const std::string path = (test::scratchDir("ply") / "map.ply").string();
  std::vector<PlyPoint> points;
  for (int i = 0; i < 100; ++i)
    points.push_back({Vec3(0.25 * i, -1.5 + i, 1e-3 * i), cv::Vec3b(i, 2 * i, 255 - i), i % 7 == 0 ? -1 : i % 80});
  writeMapPly(path, points);
  const std::vector<PlyPoint> back = readMapPly(path);
  ASSERT_EQ(back.size(), points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    EXPECT_TRUE(back[i].position.isApprox(points[i].position.cast<float>().cast<double>(), 1e-12)) << i;
    EXPECT_EQ(back[i].bgr, points[i].bgr) << i;
    EXPECT_EQ(back[i].class_id, points[i].class_id) << i;
  }
  // Header says what the file holds; 19 bytes per vertex follow it.
  std::ifstream file(path, std::ios::binary);
  const std::string content((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  EXPECT_NE(content.find("format binary_little_endian 1.0"), std::string::npos);
  EXPECT_NE(content.find("property uchar red\nproperty uchar green\nproperty uchar blue\nproperty int class_id\n"),
            std::string::npos);
  EXPECT_EQ(content.size() - (content.find("end_header\n") + 11), 100u * 19u);
}

TEST(Ply, EmptyCloudRoundTrips) {
  const std::string path = (test::scratchDir("ply_empty") / "map.ply").string();
  writeMapPly(path, {});
  EXPECT_TRUE(readMapPly(path).empty());
}

TEST(Ply, ReadsAsciiFromOtherToolsWithoutClassId) {
  // As MeshLab writes it: normals, alpha, and a face element after the vertices.
  const std::string path = (test::scratchDir("ply_ascii") / "cloud.ply").string();
  std::ofstream(path) << "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nelement vertex 2\r\n"
                         "property float x\r\nproperty float y\r\nproperty float z\r\n"
                         "property float nx\r\nproperty float ny\r\nproperty float nz\r\n"
                         "property uchar red\r\nproperty uchar green\r\nproperty uchar blue\r\nproperty uchar alpha\r\n"
                         "element face 1\r\nproperty list uchar int vertex_indices\r\nend_header\r\n"
                         "1 2 3 0 0 1 10 20 30 255\r\n-4 5.5 6 0 1 0 200 100 0 255\r\n3 0 1 1\r\n";
  const std::vector<PlyPoint> points = readMapPly(path);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points[1].position, Vec3(-4, 5.5, 6));
  EXPECT_EQ(points[0].bgr, cv::Vec3b(30, 20, 10));
  EXPECT_EQ(points[1].class_id, -1);
}

TEST(Ply, ReadsBinaryWithFloatColoursAndNoColour) {
  const auto dir = test::scratchDir("ply_float_colour");
  // Open3D-style: double positions, float colours in [0, 1]; big-endian to exercise the swap.
  std::string data = "ply\nformat binary_big_endian 1.0\nelement vertex 1\nproperty double x\nproperty double y\n"
                     "property double z\nproperty float red\nproperty float green\nproperty float blue\nend_header\n";
  auto appendBigEndian = [&](auto value) {
    char bytes[sizeof value];
    std::memcpy(bytes, &value, sizeof value);
    std::reverse(bytes, bytes + sizeof value);  // the test machine is little-endian
    data.append(bytes, sizeof value);
  };
  appendBigEndian(1.5);
  appendBigEndian(-2.0);
  appendBigEndian(3.25);
  appendBigEndian(1.0f);
  appendBigEndian(0.5f);
  appendBigEndian(0.0f);
  std::ofstream((dir / "open3d.ply").string(), std::ios::binary) << data;
  const std::vector<PlyPoint> points = readMapPly((dir / "open3d.ply").string());
  ASSERT_EQ(points.size(), 1u);
  EXPECT_EQ(points[0].position, Vec3(1.5, -2.0, 3.25));
  EXPECT_EQ(points[0].bgr, cv::Vec3b(0, 128, 255));

  std::ofstream((dir / "xyz.ply").string()) << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                                               "property float y\nproperty float z\nend_header\n7 8 9\n";
  const std::vector<PlyPoint> plain = readMapPly((dir / "xyz.ply").string());
  ASSERT_EQ(plain.size(), 1u);
  EXPECT_EQ(plain[0].bgr, cv::Vec3b(0, 0, 0));
}

TEST(Ply, ErrorsNameTheFileAndTheProblem) {
  const auto dir = test::scratchDir("ply_errors");
  EXPECT_NE(errorOf("/nonexistent/map.ply").find("/nonexistent/map.ply: cannot open"), std::string::npos);

  const std::string not_ply = (dir / "not.ply").string();
  std::ofstream(not_ply) << "hello\n";
  EXPECT_NE(errorOf(not_ply).find(not_ply + ":1: not a PLY file"), std::string::npos) << errorOf(not_ply);

  const std::string no_xyz = (dir / "no_xyz.ply").string();
  std::ofstream(no_xyz) << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float u\nend_header\n1\n";
  EXPECT_NE(errorOf(no_xyz).find("no x, y and z"), std::string::npos) << errorOf(no_xyz);

  const std::string bad_type = (dir / "bad_type.ply").string();
  std::ofstream(bad_type) << "ply\nformat ascii 1.0\nelement vertex 1\nproperty quaternion x\nend_header\n";
  EXPECT_NE(errorOf(bad_type).find(bad_type + ":4: unknown property type"), std::string::npos) << errorOf(bad_type);

  // A binary file cut short names the vertex where the data ran out.
  const std::string truncated = (dir / "truncated.ply").string();
  writeMapPly(truncated, std::vector<PlyPoint>(3));
  std::filesystem::resize_file(truncated, std::filesystem::file_size(truncated) - 5);
  const std::string message = errorOf(truncated);
  EXPECT_NE(message.find(truncated), std::string::npos) << message;
  EXPECT_NE(message.find("vertex 2 of 3"), std::string::npos) << message;
  EXPECT_NE(message.find("truncated"), std::string::npos) << message;
}

// Found by the ply fuzz target (docs/FUZZING.md).
TEST(Ply, HeaderCountsAndValuesAreNotTrusted) {
  const auto dir = test::scratchDir("ply_untrusted");
  const std::string header = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                             "property float z\nproperty int class_id\nend_header\n";
  // A class_id beyond int was cast to int: undefined behaviour.
  const std::string huge_class = (dir / "huge_class.ply").string();
  std::ofstream(huge_class) << header << "1 2 3 1e30\n";
  EXPECT_NE(errorOf(huge_class).find(huge_class + ": vertex 0 of 1: class_id 1000000000000000019884624838656.000000 is not an int"),
            std::string::npos)
      << errorOf(huge_class);
  const std::string fraction = (dir / "fraction.ply").string();
  std::ofstream(fraction) << header << "1 2 3 2.5\n";
  EXPECT_NE(errorOf(fraction).find("class_id 2.500000 is not an int"), std::string::npos) << errorOf(fraction);

  // A vertex count of 9e18 was reserved up front (std::length_error, not an InputError).
  const std::string huge_count = (dir / "huge_count.ply").string();
  std::ofstream(huge_count) << "ply\nformat binary_little_endian 1.0\nelement vertex 9000000000000000000\n"
                               "property float x\nproperty float y\nproperty float z\nend_header\n";
  EXPECT_NE(errorOf(huge_count).find("vertex 0 of 9000000000000000000: unexpected end of file"), std::string::npos)
      << errorOf(huge_count);

  // An ASCII list count of 3e29 was cast to long: undefined behaviour.
  const std::string huge_list = (dir / "huge_list.ply").string();
  std::ofstream(huge_list) << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                              "property float z\nproperty list uchar int ids\nend_header\n1 2 3 3e29 1 2\n";
  EXPECT_NE(errorOf(huge_list).find("vertex 0 of 1: list ids has a count of 299999999999999991891638616064.000000"),
            std::string::npos)
      << errorOf(huge_list);

  // An element without properties and a count of 9e18 was looped over, reading nothing, 9e18 times.
  const std::string empty_element = (dir / "empty_element.ply").string();
  std::ofstream(empty_element) << "ply\nformat ascii 1.0\nelement face 9000000000000000000\nelement vertex 1\n"
                                  "property float x\nproperty float y\nproperty float z\nend_header\n4 5 6\n";
  const std::vector<PlyPoint> points = readMapPly(empty_element);
  ASSERT_EQ(points.size(), 1u);
  EXPECT_EQ(points[0].position, Vec3(4, 5, 6));
}

}  // namespace
}  // namespace vslam
