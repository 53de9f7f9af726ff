// Text format of a recorded bundle problem (one record per line, '#' lines ignored):
//   vslam_bundle_problem 1
//   camera fx fy cx cy width height bf
//   keyframes N
//   id fixed fix_translation_norm r00 r01 r02 r10 r11 r12 r20 r21 r22 tx ty tz   (N lines, R and t of T_cw)
//   points M
//   id fixed x y z                                                               (M lines)
//   observations K
//   keyframe_index point_index u v inv_sigma2 u_right                             (K lines)
// u_right is "-" for a monocular observation (version 2; version 1 files,
// still read, marked one by a negative u_right).
// Numbers are written with 17 significant digits, so a save/load round trip is exact.
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>

#include "vslam/core/error.hpp"
#include "vslam/optimize/bundle_adjuster.hpp"

namespace vslam {
namespace {

constexpr const char* kMagic = "vslam_bundle_problem";
constexpr int kVersion = 2;
constexpr int kOldestVersion = 1;

// Reads the file line by line, skipping comments, and reports errors with the line number.
class LineReader {
 public:
  LineReader(std::istream& in, const std::string& path) : path_(path), in_(in) {}

  std::istringstream next(const char* what) {
    std::string line;
    while (std::getline(in_, line)) {
      ++line_number_;
      if (!line.empty() && line[0] != '#') return std::istringstream(line);
    }
    throw InputError(path_, line_number_, std::string("unexpected end of file, expected ") + what);
  }

  template <typename... Values>
  void parse(std::istringstream& line, const char* what, Values&... values) {
    (line >> ... >> values);
    if (line.fail()) fail(std::string("malformed ") + what);
  }

  // "<keyword> <count>" header line.
  size_t count(const char* keyword) {
    std::istringstream line = next(keyword);
    std::string word;
    long n = -1;
    line >> word >> n;
    if (line.fail() || word != keyword || n < 0) fail(std::string("expected '") + keyword + " <count>'");
    return static_cast<size_t>(n);
  }

  [[noreturn]] void fail(const std::string& what) const { throw InputError(path_, line_number_, what); }

 private:
  std::string path_;
  std::istream& in_;
  int line_number_ = 0;
};

}  // namespace

void saveBundleProblem(const std::string& path, const PinholeCamera& camera, double bf,
                       const BundleProblem& problem) {
  std::ofstream out(path);
  if (!out) throw InputError(path, 0, "cannot write bundle problem file");
  out << std::setprecision(std::numeric_limits<double>::max_digits10);
  out << kMagic << ' ' << kVersion << '\n';
  out << "camera " << camera.fx << ' ' << camera.fy << ' ' << camera.cx << ' ' << camera.cy << ' ' << camera.width
      << ' ' << camera.height << ' ' << bf << '\n';
  out << "keyframes " << problem.keyframes.size() << '\n';
  for (const BaKeyframe& kf : problem.keyframes) {
    out << kf.id << ' ' << kf.fixed << ' ' << kf.fix_translation_norm;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) out << ' ' << kf.T_cw.R(r, c);
    }
    out << ' ' << kf.T_cw.t.x() << ' ' << kf.T_cw.t.y() << ' ' << kf.T_cw.t.z() << '\n';
  }
  out << "points " << problem.points.size() << '\n';
  for (const BaPoint& point : problem.points) {
    out << point.id << ' ' << point.fixed << ' ' << point.position_w.x() << ' ' << point.position_w.y() << ' '
        << point.position_w.z() << '\n';
  }
  out << "observations " << problem.observations.size() << '\n';
  for (const BaObservation& obs : problem.observations) {
    out << obs.keyframe << ' ' << obs.point << ' ' << obs.pixel.x() << ' ' << obs.pixel.y() << ' ' << obs.inv_sigma2
        << ' ';
    if (hasRightCoordinate(obs.u_right))
      out << obs.u_right << '\n';
    else
      out << "-\n";
  }
  if (!out) throw InputError(path, 0, "error while writing bundle problem file");
}

RecordedBundleProblem loadBundleProblem(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open bundle problem file");
  return loadBundleProblem(in, path);
}

RecordedBundleProblem loadBundleProblem(std::istream& in, const std::string& path) {
  LineReader reader(in, path);
  RecordedBundleProblem recorded;
  int file_version = 0;
  {
    std::istringstream line = reader.next("header");
    std::string magic;
    int version = 0;
    line >> magic >> version;
    if (magic != kMagic || version < kOldestVersion || version > kVersion) {
      reader.fail(std::string("not a '") + kMagic + " " + std::to_string(kOldestVersion) + ".." +
                  std::to_string(kVersion) + "' file");
    }
    file_version = version;
  }
  {
    std::istringstream line = reader.next("camera");
    std::string word;
    PinholeCamera& camera = recorded.camera;
    reader.parse(line, "camera line", word, camera.fx, camera.fy, camera.cx, camera.cy, camera.width,
                 camera.height, recorded.bf);
    if (word != "camera") reader.fail("expected 'camera fx fy cx cy width height bf'");
  }
  // Counts come from the file: records are appended as they are read, so a
  // count of 2e8 over a short file is "unexpected end of file", not 30 GB
  // allocated up front (found by the bundle_problem fuzz target).
  BundleProblem& problem = recorded.problem;
  const size_t keyframe_count = reader.count("keyframes");
  while (problem.keyframes.size() < keyframe_count) {
    BaKeyframe& kf = problem.keyframes.emplace_back();
    std::istringstream line = reader.next("keyframe");
    Mat3& R = kf.T_cw.R;
    Vec3& t = kf.T_cw.t;
    reader.parse(line, "keyframe line", kf.id, kf.fixed, kf.fix_translation_norm, R(0, 0), R(0, 1), R(0, 2),
                 R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2), t.x(), t.y(), t.z());
  }
  const size_t point_count = reader.count("points");
  while (problem.points.size() < point_count) {
    BaPoint& point = problem.points.emplace_back();
    std::istringstream line = reader.next("point");
    Vec3& p = point.position_w;
    reader.parse(line, "point line", point.id, point.fixed, p.x(), p.y(), p.z());
  }
  const size_t observation_count = reader.count("observations");
  const int n_keyframes = static_cast<int>(problem.keyframes.size());
  const int n_points = static_cast<int>(problem.points.size());
  while (problem.observations.size() < observation_count) {
    BaObservation& obs = problem.observations.emplace_back();
    std::istringstream line = reader.next("observation");
    std::string right;
    reader.parse(line, "observation line", obs.keyframe, obs.point, obs.pixel.x(), obs.pixel.y(), obs.inv_sigma2,
                 right);
    if (right == "-") {
      obs.u_right = kNoRightCoordinate;
    } else {
      std::istringstream number(right);
      if (!(number >> obs.u_right) || !number.eof()) reader.fail("malformed u_right '" + right + "'");
      if (file_version == 1 && obs.u_right < 0) obs.u_right = kNoRightCoordinate;
    }
    if (obs.keyframe < 0 || obs.keyframe >= n_keyframes || obs.point < 0 || obs.point >= n_points) {
      reader.fail("observation index out of range");
    }
  }
  return recorded;
}

}  // namespace vslam
