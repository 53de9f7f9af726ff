#include "vslam/io/trajectory_io.hpp"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <memory>

#include "vslam/core/error.hpp"
#include "vslam/io/text_table.hpp"

namespace vslam {
namespace {

// KITTI files store R with ~7 significant digits; anything further from a
// rotation than this is not a pose (e.g. a TUM line read as KITTI).
constexpr double kRotationTolerance = 1e-2;

void checkIncreasing(double previous, double current, const std::string& path, int line) {
  if (current <= previous) {
    char text[160];
    std::snprintf(text, sizeof(text), "timestamp %.6f does not increase (previous line has %.6f)", current, previous);
    throw InputError(path, line, text);
  }
}

using FilePtr = std::unique_ptr<std::FILE, int (*)(std::FILE*)>;

FilePtr openForWriting(const std::string& path) {
  FilePtr file(std::fopen(path.c_str(), "w"), &std::fclose);
  if (!file) throw InputError(path, 0, "cannot open file for writing");
  return file;
}

void finishWriting(FilePtr& file, const std::string& path) {
  const bool failed = std::ferror(file.get()) != 0;
  if (std::fclose(file.release()) != 0 || failed) throw InputError(path, 0, "write error");
}

std::vector<StampedPose> tumTrajectoryFromRows(const std::vector<TextRow>& rows, const std::string& path) {
  std::vector<StampedPose> poses;
  for (const TextRow& row : rows) {
    if (row.fields.size() != 8) {
      std::string what =
          "expected 8 fields 'timestamp tx ty tz qx qy qz qw', found " + std::to_string(row.fields.size());
      if (row.fields.size() == 12) what += " (a KITTI trajectory? use the KITTI format)";
      throw InputError(path, row.line, what);
    }
    double v[8];
    static const char* const kNames[8] = {"timestamp", "tx", "ty", "tz", "qx", "qy", "qz", "qw"};
    for (int k = 0; k < 8; ++k) v[k] = parseNumber(row.fields[k], path, row.line, kNames[k]);
    const Quat q(v[7], v[4], v[5], v[6]);  // Eigen takes (w, x, y, z)
    if (std::abs(q.norm() - 1.0) > 0.1)
      throw InputError(path, row.line, "quaternion (qx qy qz qw) has norm " + std::to_string(q.norm()) + ", not 1");
    if (!poses.empty()) checkIncreasing(poses.back().timestamp, v[0], path, row.line);
    StampedPose pose;
    pose.timestamp = v[0];
    pose.T_wc = SE3(q, Vec3(v[1], v[2], v[3]));
    poses.push_back(pose);
  }
  return poses;
}

std::vector<StampedPose> kittiTrajectoryFromRows(const std::vector<TextRow>& rows, const std::string& path,
                                                 const std::vector<double>& timestamps) {
  if (!timestamps.empty() && timestamps.size() != rows.size())
    throw InputError(path, 0,
                     "has " + std::to_string(rows.size()) + " poses but there are " +
                         std::to_string(timestamps.size()) + " timestamps (one pose per frame expected)");
  std::vector<StampedPose> poses;
  poses.reserve(rows.size());
  for (size_t i = 0; i < rows.size(); ++i) {
    const TextRow& row = rows[i];
    if (row.fields.size() != 12) {
      std::string what =
          "expected 12 numbers (3x4 matrix [R|t], row-major), found " + std::to_string(row.fields.size());
      if (row.fields.size() == 8) what += " (a TUM trajectory? use the TUM format)";
      throw InputError(path, row.line, what);
    }
    Mat4 m = Mat4::Identity();
    for (int k = 0; k < 12; ++k)
      m(k / 4, k % 4) = parseNumber(row.fields[k], path, row.line, "matrix entry " + std::to_string(k + 1));
    const Mat3 R = m.topLeftCorner<3, 3>();
    const double orthogonality_error = (R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff();
    if (orthogonality_error > kRotationTolerance || R.determinant() <= 0)
      throw InputError(path, row.line, "the 3x3 part is not a rotation matrix");
    StampedPose pose;
    pose.timestamp = timestamps.empty() ? static_cast<double>(i) : timestamps[i];
    pose.T_wc = SE3::fromMatrix(m);
    poses.push_back(pose);
  }
  return poses;
}

}  // namespace

std::vector<StampedPose> readTumTrajectory(const std::string& path) {
  return tumTrajectoryFromRows(readTextRows(path), path);
}

std::vector<StampedPose> readTumTrajectory(std::istream& in, const std::string& name) {
  return tumTrajectoryFromRows(readTextRows(in, name), name);
}

std::vector<StampedPose> readKittiTrajectory(const std::string& path, const std::vector<double>& timestamps) {
  return kittiTrajectoryFromRows(readTextRows(path), path, timestamps);
}

std::vector<StampedPose> readKittiTrajectory(std::istream& in, const std::string& name,
                                             const std::vector<double>& timestamps) {
  return kittiTrajectoryFromRows(readTextRows(in, name), name, timestamps);
}

void writeTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses) {
  FilePtr file = openForWriting(path);
  std::fprintf(file.get(), "# timestamp tx ty tz qx qy qz qw\n");
  for (const StampedPose& pose : poses) {
    const Quat q = pose.T_wc.quaternion().normalized();
    const Vec3& t = pose.T_wc.t;
    std::fprintf(file.get(), "%.6f %.9g %.9g %.9g %.9g %.9g %.9g %.9g\n", pose.timestamp, t.x(), t.y(), t.z(), q.x(),
                 q.y(), q.z(), q.w());
  }
  finishWriting(file, path);
}

void writeKittiTrajectory(const std::string& path, const std::vector<StampedPose>& poses) {
  FilePtr file = openForWriting(path);
  for (const StampedPose& pose : poses) {
    const Mat4 m = pose.T_wc.matrix();
    // + 0.0 turns -0 into 0, which reads the same but looks less like a sign error.
    for (int k = 0; k < 12; ++k) std::fprintf(file.get(), k == 0 ? "%.9g" : " %.9g", m(k / 4, k % 4) + 0.0);
    std::fprintf(file.get(), "\n");
  }
  finishWriting(file, path);
}

std::string kittiFrameIndexPath(const std::string& trajectory_path) {
  const std::filesystem::path path(trajectory_path);
  return (path.parent_path() / (path.stem().string() + "_frames" + path.extension().string())).string();
}

std::vector<int> readFrameIndexFile(const std::string& path) {
  std::vector<int> frames;
  for (const TextRow& row : readTextRows(path)) {
    if (row.fields.size() != 1)
      throw InputError(path, row.line, "expected 1 field (a frame index), found " + std::to_string(row.fields.size()));
    const std::string& field = row.fields[0];
    char* end = nullptr;
    const long value = std::strtol(field.c_str(), &end, 10);
    if (field.empty() || *end != '\0' || value < 0 || value > std::numeric_limits<int>::max())
      throw InputError(path, row.line, "frame index '" + field + "' is not a non-negative integer");
    if (!frames.empty() && value <= frames.back())
      throw InputError(path, row.line,
                       "frame index " + field + " does not increase (previous line has " +
                           std::to_string(frames.back()) + ")");
    frames.push_back(static_cast<int>(value));
  }
  return frames;
}

void writeFrameIndexFile(const std::string& path, const std::vector<int>& frames) {
  FilePtr file = openForWriting(path);
  for (int frame : frames) std::fprintf(file.get(), "%d\n", frame);
  finishWriting(file, path);
}

}  // namespace vslam
