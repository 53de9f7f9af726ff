#include <algorithm>
#include <limits>
#include <numeric>
#include <random>
#include <set>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "feature_test_support.hpp"
#include "vslam/core/config.hpp"
#include "vslam/core/error.hpp"
#include "vslam/feature/matcher.hpp"
#include "vslam/feature/orb_extractor.hpp"

namespace vslam {
namespace {

// One frame's features as Tracking would hold them: raw keypoints, undistorted
// points, descriptors and a grid over the undistorted image.
struct TestFrame {
  int index = 0;  // in fr1_xyz's rgb.txt
  std::vector<cv::KeyPoint> keypoints;
  std::vector<cv::Point2f> points;
  cv::Mat descriptors;
  FeatureGrid grid;
  FeatureView view() const { return FeatureView{keypoints, points, descriptors}; }
};

const PinholeCamera& fr1Camera() {
  static const PinholeCamera camera = loadConfig(projectConfigDir() + "/tum_fr1.yaml").camera;
  return camera;
}

TestFrame loadFrame(int index) {
  const OrbExtractor extractor{OrbParams()};
  TestFrame frame;
  frame.index = index;
  extractor.extract(test::tumGray("freiburg1_xyz", index), frame.keypoints, frame.descriptors);
  std::vector<cv::Point2f> raw;
  std::vector<int> levels;
  for (const cv::KeyPoint& kp : frame.keypoints) raw.push_back(kp.pt), levels.push_back(kp.octave);
  frame.points = fr1Camera().undistort(raw);
  frame.grid = FeatureGrid(frame.points, levels, undistortedImageBounds(fr1Camera()));
  return frame;
}

// Share of the pairs (i in a, j in b) whose j lies within `tolerance` px (times
// j's level scale) of where the ground truth puts i; pairs without depth are
// left out.
struct OracleScore {
  int checked = 0, correct = 0;
};

// Independent check of a correspondence: where feature i of frame a should be in
// frame b, from a's depth image and the ground-truth poses.
class GroundTruthOracle {
 public:
  GroundTruthOracle(const TestFrame& a, const TestFrame& b) : a_(a) {
    const std::string seq = "freiburg1_xyz";
    depth_a_ = test::tumDepthNear(seq, test::tumRgbStamp(seq, a.index));
    const SE3 T_wa = test::tumPoseAt(seq, test::tumRgbStamp(seq, a.index));
    const SE3 T_wb = test::tumPoseAt(seq, test::tumRgbStamp(seq, b.index));
    T_ba_ = T_wb.inverse() * T_wa;
  }
  // False when the feature has no depth.
  bool predict(int i, cv::Point2f& in_b) const {
    const cv::Point raw(cvRound(a_.keypoints[i].pt.x), cvRound(a_.keypoints[i].pt.y));  // depth is registered to the raw image
    const std::uint16_t d = depth_a_.at<std::uint16_t>(raw);
    if (d == 0) return false;
    const Vec3 p_a = fr1Camera().unproject(Vec2(a_.points[i].x, a_.points[i].y)) * (d / 5000.0);
    const Vec2 uv = fr1Camera().project(T_ba_ * p_a);
    in_b = cv::Point2f(static_cast<float>(uv.x()), static_cast<float>(uv.y()));
    return true;
  }

 private:
  const TestFrame& a_;
  cv::Mat depth_a_;
  SE3 T_ba_;
};

OracleScore scoreAgainstGroundTruth(const TestFrame& a, const TestFrame& b,
                                    const std::vector<std::pair<int, int>>& pairs, double tolerance = 4.0) {
  const GroundTruthOracle oracle(a, b);
  OracleScore score;
  for (const auto& [i, j] : pairs) {
    cv::Point2f predicted;
    if (!oracle.predict(i, predicted)) continue;
    ++score.checked;
    score.correct += cv::norm(predicted - b.points[j]) < tolerance * std::pow(1.2, b.keypoints[j].octave);
  }
  return score;
}

// ------------------------------------------------------------------- Hamming

TEST(Hamming, CountsDifferingBitsExactly) {
  std::uint8_t buffer[2 * 32 + 1] = {};
  std::uint8_t* a = buffer + 1;  // deliberately unaligned
  std::uint8_t* b = buffer + 33;
  EXPECT_EQ(hammingDistance(a, b), 0);
  b[0] = 0x01;   // 1
  b[7] = 0x80;   // 1, top of the first word
  b[8] = 0xFF;   // 8, second word
  b[31] = 0xF0;  // 4, last byte
  EXPECT_EQ(hammingDistance(a, b), 14);
  std::memset(a, 0xFF, 32);
  EXPECT_EQ(hammingDistance(a, b), 256 - 14);

  std::mt19937 rng(3);
  cv::Mat m(2, 32, CV_8U);
  for (int trial = 0; trial < 100; ++trial) {
    int expected = 0;
    for (int i = 0; i < 32; ++i) {
      m.at<std::uint8_t>(0, i) = static_cast<std::uint8_t>(rng());
      m.at<std::uint8_t>(1, i) = static_cast<std::uint8_t>(rng());
      for (int bit = 0; bit < 8; ++bit) expected += ((m.at<std::uint8_t>(0, i) ^ m.at<std::uint8_t>(1, i)) >> bit) & 1;
    }
    ASSERT_EQ(hammingDistance(m.row(0), m.row(1)), expected);
  }
}

TEST(Hamming, NearestTwoAmongCandidates) {
  cv::Mat descriptors(5, 32, CV_8U, cv::Scalar(0));
  const std::uint8_t query[32] = {};
  descriptors.at<std::uint8_t>(0, 0) = 0x0F;  // distance 4
  descriptors.at<std::uint8_t>(1, 5) = 0x01;  // 1
  descriptors.at<std::uint8_t>(2, 9) = 0x03;  // 2
  descriptors.at<std::uint8_t>(3, 1) = 0x03;  // 2, after row 2
  descriptors.at<std::uint8_t>(4, 2) = 0xFF;  // 8
  NearestTwo r = nearestTwo(query, descriptors, {0, 4, 3, 1, 2});
  EXPECT_EQ(r.index, 1);
  EXPECT_EQ(r.distance, 1);
  EXPECT_EQ(r.second_index, 3);  // first of the two at distance 2 in candidate order
  EXPECT_EQ(r.second_distance, 2);
  r = nearestTwo(query, descriptors, {4});
  EXPECT_EQ(r.index, 4);
  EXPECT_EQ(r.distance, 8);
  EXPECT_EQ(r.second_index, -1);
  EXPECT_EQ(nearestTwo(query, descriptors, {}).index, -1);
}

// ---------------------------------------------------------------- FeatureGrid

TEST(FeatureGrid, QueryEqualsBruteForce) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> x(-30.f, 670.f), y(-30.f, 510.f);  // some outside the bounds
  std::uniform_int_distribution<int> level(0, 7);
  std::vector<cv::Point2f> points;
  std::vector<int> levels;
  for (int i = 0; i < 3000; ++i) points.emplace_back(x(rng), y(rng)), levels.push_back(level(rng));
  const FeatureGrid grid(points, levels, cv::Rect2f(0, 0, 640, 480));

  std::uniform_real_distribution<float> radius(0.f, 120.f);
  std::uniform_int_distribution<int> bound(-1, 7);
  for (int q = 0; q < 300; ++q) {
    const float qx = x(rng), qy = y(rng), r = radius(rng);
    int lo = bound(rng), hi = bound(rng);
    if (lo >= 0 && hi >= 0 && lo > hi) std::swap(lo, hi);
    std::vector<int> expected;
    for (int i = 0; i < 3000; ++i) {
      if ((lo >= 0 && levels[i] < lo) || (hi >= 0 && levels[i] > hi)) continue;
      if (std::abs(points[i].x - qx) <= r && std::abs(points[i].y - qy) <= r) expected.push_back(i);
    }
    std::vector<int> found = grid.featuresInArea(qx, qy, r, lo, hi);
    std::sort(found.begin(), found.end());
    ASSERT_EQ(found, expected) << "query " << q << " at " << qx << "," << qy << " r " << r;
  }
}

TEST(FeatureGrid, EmptyAndDegenerateInputs) {
  const FeatureGrid empty({}, {}, cv::Rect2f(0, 0, 640, 480));
  EXPECT_TRUE(empty.featuresInArea(100, 100, 50).empty());
  const FeatureGrid one({cv::Point2f(10, 10)}, {}, cv::Rect2f(0, 0, 640, 480));
  EXPECT_EQ(one.featuresInArea(10, 10, 0).size(), 1u);
  EXPECT_TRUE(one.featuresInArea(10, 10, 5, 1).empty());  // level 0 < min_level 1
  EXPECT_THROW(FeatureGrid({cv::Point2f(1, 1)}, {0, 1}, cv::Rect2f(0, 0, 10, 10)), InputError);
  // A point that failed to undistort (NaN) is stored but never found.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const FeatureGrid with_nan({cv::Point2f(nan, nan), cv::Point2f(5, 5)}, {}, cv::Rect2f(0, 0, 640, 480));
  EXPECT_EQ(with_nan.featuresInArea(5, 5, 1000), std::vector<int>{1});
}

// ---------------------------------------------------------- RotationHistogram

TEST(RotationHistogram, KeepsTheThreeFullestBins) {
  RotationHistogram histogram;  // 30 bins of 12 degrees, bin 0 = [-6, 6)
  int index = 0;
  std::vector<int> bin0, bin5, bin10, bin15;
  for (int i = 0; i < 10; ++i) bin0.push_back(index), histogram.add(100.f + i * 0.5f, 100.f, index++);   // 0..4.5 deg
  histogram.add(3.f, 358.f, index), bin0.push_back(index++);                                              // +5 wraps into bin 0
  histogram.add(358.f, 3.f, index), bin0.push_back(index++);                                              // -5 too
  for (int i = 0; i < 4; ++i) bin5.push_back(index), histogram.add(60.f, 0.f, index++);                   // 60 deg
  for (int i = 0; i < 2; ++i) bin10.push_back(index), histogram.add(0.f, 240.f, index++);                 // 120 deg
  bin15.push_back(index), histogram.add(180.f, 0.f, index++);                                             // 180 deg

  EXPECT_EQ(histogram.binOf(3.f, 358.f), 0);
  EXPECT_EQ(histogram.binOf(60.f, 0.f), 5);
  EXPECT_EQ(histogram.keptBins(), (std::vector<int>{0, 5, 10}));
  EXPECT_EQ(histogram.rejectedMatches(), bin15);
  std::vector<int> consistent = bin0;
  consistent.insert(consistent.end(), bin5.begin(), bin5.end());
  consistent.insert(consistent.end(), bin10.begin(), bin10.end());
  EXPECT_EQ(histogram.consistentMatches(), consistent);
}

TEST(RotationHistogram, DropsBinsUnderATenthOfTheFullest) {
  RotationHistogram histogram;
  for (int i = 0; i < 25; ++i) histogram.add(90.f, 0.f, i);  // bin 7 (90 / 12 = 7.5 rounds to 8? no: 7.5 + 0.5 -> 8)
  histogram.add(10.f, 0.f, 25);                              // 2 matches in bin 1: 2 * 10 < 25, dropped
  histogram.add(11.f, 0.f, 26);
  histogram.add(200.f, 0.f, 27);                             // 3 in bin 17: 30 >= 25, kept
  histogram.add(201.f, 0.f, 28);
  histogram.add(202.f, 0.f, 29);
  EXPECT_EQ(histogram.binOf(90.f, 0.f), 8);
  EXPECT_EQ(histogram.keptBins(), (std::vector<int>{8, 17}));
  EXPECT_EQ(histogram.rejectedMatches(), (std::vector<int>{25, 26}));
  EXPECT_TRUE(RotationHistogram().keptBins().empty());
}

// --------------------------------------------------------------- matchByRatio

TEST(MatchByRatio, RecoversAPermutationAndRejectsAmbiguity) {
  std::mt19937 rng(5);
  cv::Mat set1(40, 32, CV_8U);
  for (int i = 0; i < set1.rows; ++i)
    for (int j = 0; j < 32; ++j) set1.at<std::uint8_t>(i, j) = static_cast<std::uint8_t>(rng());
  std::vector<int> permutation(40);
  std::iota(permutation.begin(), permutation.end(), 0);
  std::shuffle(permutation.begin(), permutation.end(), rng);
  cv::Mat set2(41, 32, CV_8U);
  for (int i = 0; i < 40; ++i) {
    set1.row(i).copyTo(set2.row(permutation[i]));
    set2.at<std::uint8_t>(permutation[i], i % 32) ^= 0x11;  // 2 bits of noise
  }
  set1.row(7).copyTo(set2.row(40));  // a second, equally good candidate for row 7
  set2.at<std::uint8_t>(40, 3) ^= 0x03;

  const std::vector<cv::DMatch> matches = matchByRatio(set1, set2, 0.8f, kHammingThresholdLow);
  EXPECT_EQ(matches.size(), 39u);
  for (const cv::DMatch& m : matches) {
    EXPECT_NE(m.queryIdx, 7);
    EXPECT_EQ(m.trainIdx, permutation[m.queryIdx]);
    EXPECT_EQ(m.distance, 2.f);
  }
}

// ------------------------------------------------------------------ epipolar

TEST(Epipolar, FundamentalFromPosesMatchesProjections) {
  const Mat3 K = fr1Camera().Keigen();
  const SE3 T_1w(Quat(Eigen::AngleAxisd(0.1, Vec3(0, 1, 0))), Vec3(0.1, 0, 0));
  const SE3 T_2w(Quat(Eigen::AngleAxisd(-0.05, Vec3(1, 0.2, 0).normalized())), Vec3(-0.2, 0.05, 0.1));
  const cv::Matx33d F21 = fundamentalFromPoses(T_1w, T_2w, K, K);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1, 1), depth(2, 5);
  std::vector<cv::Point2f> points1, points2;
  for (int i = 0; i < 50; ++i) {
    const Vec3 p_w = T_1w.inverse() * Vec3(u(rng), u(rng), depth(rng));
    const Vec2 a = fr1Camera().project(T_1w * p_w), b = fr1Camera().project(T_2w * p_w);
    points1.emplace_back(static_cast<float>(a.x()), static_cast<float>(a.y()));
    points2.emplace_back(static_cast<float>(b.x()), static_cast<float>(b.y()));
    EXPECT_LT(epipolarDistanceSquared(F21, points1.back(), points2.back()), 1e-4);
    EXPECT_TRUE(isEpipolarConsistent(F21, points1.back(), points2.back(), 1.0));
  }
  // Off the line: move p2 along the line's normal.
  const cv::Vec3d line = F21 * cv::Vec3d(points1[0].x, points1[0].y, 1);
  const cv::Point2f normal(static_cast<float>(line[0] / std::hypot(line[0], line[1])),
                           static_cast<float>(line[1] / std::hypot(line[0], line[1])));
  EXPECT_NEAR(epipolarDistanceSquared(F21, points1[0], points2[0] + 3.f * normal), 9.0, 0.01);
  EXPECT_FALSE(isEpipolarConsistent(F21, points1[0], points2[0] + 3.f * normal, 1.0));    // 9 > 3.84
  EXPECT_TRUE(isEpipolarConsistent(F21, points1[0], points2[0] + 3.f * normal, 1.2 * 1.2 * 1.2 * 1.2 * 1.2 * 1.2));  // level 3: 3.84 * 2.99
  // Same convention as OpenCV: F from the 8-point algorithm equals ours up to scale.
  cv::Mat F_cv = cv::findFundamentalMat(points1, points2, cv::FM_8POINT);
  cv::Matx33d ours = F21 * (1.0 / cv::norm(F21)), theirs = cv::Matx33d(F_cv) * (1.0 / cv::norm(F_cv));
  if (ours.dot(theirs) < 0) theirs = theirs * -1.0;
  EXPECT_LT(cv::norm(ours - theirs), 1e-3);
}

// ------------------------------------------------------- real fr1_xyz frames

struct Inliers {
  int matches = 0, inliers = 0;
  cv::Mat F21;
  cv::Mat mask;  // per match: inlier or not
};

// Matches consistent with a fundamental matrix from RANSAC: within `pixels` of
// the epipolar lines in both images. 1.96 px is ORB-SLAM's initialiser rule
// (sigma 1 px, chi^2 3.84).
Inliers fundamentalInliers(const std::vector<cv::Point2f>& p1, const std::vector<cv::Point2f>& p2, double pixels = 1.96) {
  Inliers result;
  result.matches = static_cast<int>(p1.size());
  result.F21 = cv::findFundamentalMat(p1, p2, cv::FM_RANSAC, pixels, 0.999, result.mask);
  result.inliers = cv::countNonZero(result.mask);
  return result;
}

TEST(MatchInWindow, ConsecutiveFr1FramesMatchConsistently) {
  const TestFrame f1 = loadFrame(0), f2 = loadFrame(1);
  std::vector<cv::Point2f> prev = f1.points;
  const WindowMatches result = matchInWindow(f1.view(), f2.view(), f2.grid, prev);

  std::vector<cv::Point2f> p1, p2;
  std::vector<std::pair<int, int>> pairs;
  std::set<int> used2;
  int counted = 0;
  for (int i1 = 0; i1 < static_cast<int>(result.matches12.size()); ++i1) {
    const int i2 = result.matches12[i1];
    if (i2 < 0) {
      EXPECT_EQ(prev[i1], f1.points[i1]);  // unmatched: left alone
      continue;
    }
    ++counted;
    EXPECT_EQ(f1.keypoints[i1].octave, 0);
    EXPECT_EQ(f2.keypoints[i2].octave, 0);
    EXPECT_TRUE(used2.insert(i2).second) << "frame-2 feature " << i2 << " matched twice";
    EXPECT_LE(hammingDistance(f1.descriptors.row(i1), f2.descriptors.row(i2)), kHammingThresholdWindow);
    EXPECT_EQ(prev[i1], f2.points[i2]);
    p1.push_back(f1.points[i1]), p2.push_back(f2.points[i2]), pairs.emplace_back(i1, i2);
  }
  EXPECT_EQ(counted, result.count);
  const OracleScore truth = scoreAgainstGroundTruth(f1, f2, pairs);
  const Inliers strict = fundamentalInliers(p1, p2, 1.96), loose = fundamentalInliers(p1, p2, 3.0);
  std::cout << "frames 1->2: " << result.count << " matches, " << strict.inliers << " consistent with F at 1.96 px, "
            << loose.inliers << " at 3 px; " << truth.correct << " of " << truth.checked
            << " with depth within 4 px of the ground-truth prediction\n";
  // Measured: 85 matches (of 217 level-0 features); 73 within 1.96 px of F,
  // 78 within 3 px; 58 of 67 right by ground truth (the random BRIEF pattern
  // before issue 16, at distance 50: 91, 73, 80, 58 of 71). The wrong ones are mostly
  // on the keyboard (repeated keys inside the 100 px window) and on weak
  // corners; a single pair moves by several % with any change of keypoints, so
  // the precision rule is checked over ten pairs below.
  EXPECT_GE(result.count, 75);
  EXPECT_GE(strict.inliers, 0.75 * result.count);
  EXPECT_GE(loose.inliers, 0.85 * result.count);
  EXPECT_GE(truth.correct, 0.75 * truth.checked);
}

TEST(MatchInWindow, CoarserLevelsAreSearchedWithinTheirOwnLevelWhenAsked) {
  const TestFrame f1 = loadFrame(0), f2 = loadFrame(1);
  std::vector<cv::Point2f> prev_finest = f1.points, prev_two = f1.points;
  const WindowMatches finest = matchInWindow(f1.view(), f2.view(), f2.grid, prev_finest);
  WindowMatchParams two_levels;
  two_levels.max_level = 1;
  const WindowMatches both = matchInWindow(f1.view(), f2.view(), f2.grid, prev_two, two_levels);
  int level0_matches = 0, level1_matches = 0;
  for (int i1 = 0; i1 < static_cast<int>(both.matches12.size()); ++i1) {
    const int i2 = both.matches12[i1];
    if (i2 < 0) continue;
    EXPECT_LE(f1.keypoints[i1].octave, 1);
    EXPECT_EQ(f1.keypoints[i1].octave, f2.keypoints[i2].octave) << "feature " << i1 << " matched across levels";
    if (f1.keypoints[i1].octave == 1) {
      ++level1_matches;
      continue;
    }
    ++level0_matches;
    // Partners are on the same level, so a level-0 feature finds the same one
    // either way; the rotation check runs over all matches, so a few level-0
    // matches can fall outside its main bins once level 1 joins.
    EXPECT_EQ(i2, finest.matches12[i1]) << i1;
  }
  std::cout << "frames 0->1: " << finest.count << " level-0 matches; on levels 0-1, " << level0_matches
            << " on level 0 and " << level1_matches << " on level 1\n";
  // Measured: 85; 76 and 77.
  EXPECT_EQ(both.count, level0_matches + level1_matches);
  EXPECT_GT(level1_matches, 30);
  EXPECT_GE(level0_matches, 0.8 * finest.count);
  EXPECT_GT(both.count, finest.count);
}

// Frames 1->2, 2->3, ..., 10->11 pooled. Measured 846 matches, 91.7 % within
// 1.96 px (ORB-SLAM's initialiser rule, sigma 1 px) of each pair's F (the
// random BRIEF pattern: 927, 87.8 %). cv::ORB's
// bunched Harris corners reach 99 % on such pairs: see docs/FEATURES.md.
TEST(MatchInWindow, TenConsecutiveFr1PairsAreMostlyConsistent) {
  int matches = 0, consistent = 0;
  TestFrame previous = loadFrame(0);
  for (int index = 1; index <= 10; ++index) {
    TestFrame current = loadFrame(index);
    std::vector<cv::Point2f> prev = previous.points;
    const WindowMatches result = matchInWindow(previous.view(), current.view(), current.grid, prev);
    std::vector<cv::Point2f> p1, p2;
    for (int i1 = 0; i1 < static_cast<int>(result.matches12.size()); ++i1)
      if (result.matches12[i1] >= 0) p1.push_back(previous.points[i1]), p2.push_back(current.points[result.matches12[i1]]);
    EXPECT_GE(result.count, 60) << "frames " << index - 1 << "->" << index;
    matches += result.count;
    consistent += fundamentalInliers(p1, p2, 1.96).inliers;
    previous = std::move(current);
  }
  std::cout << "ten pairs: " << matches << " matches, " << consistent << " within 1.96 px of F\n";
  EXPECT_GE(matches, 800);
  EXPECT_GE(consistent, 0.85 * matches);
}

TEST(SearchForTriangulation, AgreesWithEpipolarGeometryOnFr1) {
  // Frames 0 and 5 (1/6 s apart, ~25 px of image motion).
  const TestFrame f1 = loadFrame(0), f2 = loadFrame(5);
  std::vector<cv::Point2f> prev = f1.points;
  const WindowMatches window = matchInWindow(f1.view(), f2.view(), f2.grid, prev);
  std::vector<cv::Point2f> p1, p2;
  std::vector<int> matched_i1;
  for (int i1 = 0; i1 < static_cast<int>(window.matches12.size()); ++i1)
    if (window.matches12[i1] >= 0)
      p1.push_back(f1.points[i1]), p2.push_back(f2.points[window.matches12[i1]]), matched_i1.push_back(i1);
  const Inliers geometry = fundamentalInliers(p1, p2);
  ASSERT_GE(geometry.inliers, 50);
  std::vector<int> reliable12(f1.keypoints.size(), -1);  // window matches that fit F
  for (std::size_t k = 0; k < matched_i1.size(); ++k)
    if (geometry.mask.at<std::uint8_t>(static_cast<int>(k))) reliable12[matched_i1[k]] = window.matches12[matched_i1[k]];
  const cv::Matx33d F21(geometry.F21);
  const std::vector<double> sigma2 = OrbExtractor(OrbParams()).levelSigma2();

  const auto pairs = searchForTriangulation(f1.view(), f2.view(), F21, sigma2);
  const OracleScore truth = scoreAgainstGroundTruth(f1, f2, pairs);
  std::set<int> used1, used2;
  int agree = 0, both = 0;
  for (const auto& [i1, i2] : pairs) {
    EXPECT_TRUE(used1.insert(i1).second);
    EXPECT_TRUE(used2.insert(i2).second);
    EXPECT_TRUE(isEpipolarConsistent(F21, f1.points[i1], f2.points[i2], sigma2[f2.keypoints[i2].octave]));
    EXPECT_LE(hammingDistance(f1.descriptors.row(i1), f2.descriptors.row(i2)), kHammingThresholdLow);
    if (reliable12[i1] >= 0) ++both, agree += reliable12[i1] == i2;
  }
  std::cout << "frames 0-5: " << window.count << " window matches (" << geometry.inliers << " F inliers); "
            << pairs.size() << " triangulation pairs, " << agree << " of " << both
            << " shared with the F-consistent window matches; " << truth.correct << " of " << truth.checked
            << " with depth within 4 px x scale of the ground-truth prediction\n";
  EXPECT_GE(pairs.size(), 250u);  // all levels
  EXPECT_GE(truth.correct, 0.95 * truth.checked);
  EXPECT_GE(agree, 0.8 * both);  // where they differ, the window match is usually the wrong one (ground truth)

  // Masks: nothing already matched comes back.
  std::vector<bool> matched1(f1.keypoints.size(), false), matched2(f2.keypoints.size(), false);
  for (std::size_t k = 0; k < pairs.size(); k += 2) matched1[pairs[k].first] = true;
  for (std::size_t k = 1; k < pairs.size(); k += 2) matched2[pairs[k].second] = true;
  const auto rest = searchForTriangulation(f1.view(), f2.view(), F21, sigma2, matched1, matched2);
  EXPECT_FALSE(rest.empty());
  for (const auto& [i1, i2] : rest) {
    EXPECT_FALSE(matched1[i1]);
    EXPECT_FALSE(matched2[i2]);
  }
}

// Synthetic: forward motion puts the epipole at the principal point. Feature 0
// projects next to it and must not be matched; feature 1 has an identical twin
// off its epipolar line that must be ignored; the rest match one to one.
TEST(SearchForTriangulation, RejectsTheEpipoleAndOffLineTwins) {
  const PinholeCamera& camera = fr1Camera();
  const SE3 T_1w;                                    // identity
  const SE3 T_2w(Mat3::Identity(), Vec3(0, 0, -0.3));  // 0.3 m forward
  const cv::Matx33d F21 = fundamentalFromPoses(T_1w, T_2w, camera.Keigen(), camera.Keigen());
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> u(-0.8, 0.8), depth(2, 4);
  std::vector<cv::KeyPoint> k1, k2;
  std::vector<cv::Point2f> p1, p2;
  std::vector<Vec3> world;
  world.push_back(Vec3(0.002, 0.001, 3.0));  // almost on the optical axis
  for (int i = 1; i < 60; ++i) world.push_back(Vec3(u(rng), u(rng), depth(rng)));
  for (const Vec3& p : world) {
    const Vec2 a = camera.project(T_1w * p), b = camera.project(T_2w * p);
    p1.emplace_back(static_cast<float>(a.x()), static_cast<float>(a.y()));
    p2.emplace_back(static_cast<float>(b.x()), static_cast<float>(b.y()));
    k1.emplace_back(p1.back(), 31.f, 45.f, 0.f, 0);
    k2.emplace_back(p2.back(), 31.f, 47.f, 0.f, 0);
  }
  cv::Mat d1(60, 32, CV_8U), d2;
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 32; ++j) d1.at<std::uint8_t>(i, j) = static_cast<std::uint8_t>(rng());
  d2 = d1.clone();
  // The twin of feature 1: same descriptor, 20 px off the line.
  const cv::Vec3d line = F21 * cv::Vec3d(p1[1].x, p1[1].y, 1);
  const cv::Point2f normal(static_cast<float>(line[0] / std::hypot(line[0], line[1])),
                           static_cast<float>(line[1] / std::hypot(line[0], line[1])));
  p2.push_back(p2[1] + 20.f * normal);
  k2.emplace_back(p2.back(), 31.f, 47.f, 0.f, 0);
  d2.push_back(d1.row(1));

  const FeatureView v1{k1, p1, d1}, v2{k2, p2, d2};
  const auto pairs = searchForTriangulation(v1, v2, F21, {1.0});
  EXPECT_EQ(pairs.size(), 59u);
  for (const auto& [i1, i2] : pairs) {
    EXPECT_NE(i1, 0) << "matched at the epipole";
    EXPECT_EQ(i1, i2);
  }
}

}  // namespace
}  // namespace vslam
