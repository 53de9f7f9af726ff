// Place recognition in the pipeline, on real fr1_xyz frames (deterministic
// mode): relocalisation after a gap, loop closing on a forward-then-backward
// play, the final full bundle adjustment, the default vocabulary.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "system_test_support.hpp"
#include "test_support.hpp"
#include "vslam/eval/ate.hpp"
#include "vslam/io/sequence.hpp"
#include "vslam/slam/loop_closing.hpp"
#include "vslam/slam/system.hpp"
#include "vslam/place/vocabulary.hpp"
#include "vslam/render/room_loop.hpp"

namespace vslam {
namespace {

Sequence fr1Xyz() {
  SequenceOptions options;
  options.data_root = test::sharedData().string();
  return openSequence("tum/fr1_xyz", options);
}

AteResult ate(const std::vector<StampedPose>& estimate, const std::vector<StampedPose>& groundtruth) {
  AteOptions options;
  options.alignment = Alignment::Sim3;
  return computeAte(estimate, groundtruth, options);
}

// Frames 0-299, then 420-599: 120 frames (4 s) never seen. Skipping alone
// does not lose tracking on fr1_xyz (matching the reference keyframe bridges
// the gap), so the gap is also covered: three black frames (a covered lens)
// lose tracking, and the first frame after them must relocalise against the map.
TEST(SlamLoop, RelocalisesAfterSkippingFrames) {
  const Sequence sequence = fr1Xyz();
  std::vector<size_t> order;
  for (size_t i = 0; i < 300; ++i) order.push_back(i);
  for (size_t i = 420; i < 600; ++i) order.push_back(i);

  SystemOptions options;
  options.deterministic = true;
  Config config = sequence.config;
  config.detector.model = "none";  // place recognition does not depend on the detector
  config.loop.final_ba = false;
  System system(config, options);
  for (size_t i : order) {
    if (i == 420) {
      const cv::Mat black = cv::Mat::zeros(480, 640, CV_8UC3);
      for (int k = 1; k <= 3; ++k)
        EXPECT_FALSE(system.processFrame(-k, sequence.frames[299].timestamp + 0.1 * k, black));
    }
    system.processFrame(sequence.frames[i].index, sequence.frames[i].timestamp, sequence.loadColor(i));
  }
  system.finish();

  EXPECT_EQ(system.stats().relocalisations, 1);
  const std::vector<int> lost = system.lostFrameIndices();
  EXPECT_EQ(std::count_if(lost.begin(), lost.end(), [](int index) { return index >= 420; }), 0);
  const double gap_end = sequence.frames[420].timestamp;
  int tracked_after = 0;
  for (const StampedPose& pose : system.frameTrajectory()) tracked_after += pose.timestamp >= gap_end ? 1 : 0;
  EXPECT_GE(tracked_after, 0.9 * 180);
  // The map was kept: relocalised poses agree with the ground truth like the rest.
  EXPECT_LT(ate(system.keyframeTrajectory(), sequence.groundtruth).rmse_m, 0.03);
}

// Forward over frames 0..N-1, then back N-1..0. The backward frames get new,
// increasing timestamps; the ground truth used for them is that of the
// original frame, restamped the same way.
struct ForwardBackward {
  std::vector<StampedPose> keyframes;
  std::vector<StampedPose> frames;
  std::vector<LoopRecord> loops;
};

ForwardBackward runForwardBackward(const Sequence& sequence, size_t n, bool loop_closing,
                                   std::vector<StampedPose>& restamped_groundtruth) {
  std::vector<size_t> order;
  for (size_t i = 0; i < n; ++i) order.push_back(i);
  for (size_t i = n; i-- > 0;) order.push_back(i);

  SystemOptions options;
  options.deterministic = true;
  Config config = sequence.config;
  config.detector.model = "none";
  config.loop.enabled = loop_closing;
  config.loop.final_ba = false;  // compare loop closing alone
  System system(config, options);
  const double t0 = sequence.frames[0].timestamp;
  restamped_groundtruth.clear();
  for (size_t k = 0; k < order.size(); ++k) {
    const double stamp = t0 + k / 30.0;
    const FrameEntry& entry = sequence.frames[order[k]];
    // Nearest ground-truth pose of the original frame.
    const StampedPose* nearest = nullptr;
    for (const StampedPose& pose : sequence.groundtruth)
      if (!nearest || std::abs(pose.timestamp - entry.timestamp) < std::abs(nearest->timestamp - entry.timestamp))
        nearest = &pose;
    if (nearest && std::abs(nearest->timestamp - entry.timestamp) < 0.02)
      restamped_groundtruth.push_back({stamp, nearest->T_wc});
    system.processFrame(entry.index, stamp, sequence.loadColor(order[k]));
  }
  system.finish();
  return {system.keyframeTrajectory(), system.frameTrajectory(), system.loops()};
}

// Forward over 150 frames, then back over the same frames. No loop is closed
// here, rightly: the backward pass re-tracks the forward pass's map points (no
// drift to undo), so every earlier keyframe is a covisible neighbour of the
// current one, and loop detection excludes neighbours by design, as ORB-SLAM
// does (docs/LOOP_CLOSING.md; the verified loop is CirclingARoomClosesAVerifiedLoop).
// What can fail: the backward pass must reuse the map instead of growing a
// second one beside it, track nearly every frame, keep the accuracy, and
// accept no loop.
TEST(SlamLoop, ForwardThenBackwardReusesTheMap) {
  const Sequence sequence = fr1Xyz();
  constexpr size_t kFrames = 150;
  std::vector<StampedPose> groundtruth;
  const ForwardBackward run = runForwardBackward(sequence, kFrames, true, groundtruth);
  EXPECT_TRUE(run.loops.empty());
  EXPECT_GE(run.frames.size(), 0.95 * 2 * kFrames);
  // Keyframes of the backward pass (restamped after the forward one).
  const double backward_start = sequence.frames[0].timestamp + kFrames / 30.0;
  // Reusing the map, the backward pass puts each frame where the forward pass
  // put it: the same image gives the same pose. A second map growing beside
  // the first would drift away from it.
  std::map<long, Vec3> centre_at_step;
  const double t0 = sequence.frames[0].timestamp;
  for (const StampedPose& pose : run.frames) centre_at_step[std::lround((pose.timestamp - t0) * 30.0)] = pose.T_wc.t;
  std::vector<double> gaps;
  double extent = 0;
  for (long k = 0; k < static_cast<long>(kFrames); ++k) {
    auto forward = centre_at_step.find(k), backward = centre_at_step.find(2 * kFrames - 1 - k);
    if (forward == centre_at_step.end() || backward == centre_at_step.end()) continue;
    gaps.push_back((forward->second - backward->second).norm());
    for (const auto& [step, centre] : centre_at_step)
      if (step < static_cast<long>(kFrames)) extent = std::max(extent, (centre - forward->second).norm());
  }
  ASSERT_GE(gaps.size(), 0.9 * kFrames);
  std::sort(gaps.begin(), gaps.end());
  const double median_gap = gaps[gaps.size() / 2];
  EXPECT_LT(median_gap, 0.05 * extent) << "median gap " << median_gap << ", extent " << extent;
  const AteResult keyframe_ate = ate(run.keyframes, groundtruth);
  const AteResult frame_ate = ate(run.frames, groundtruth);
  EXPECT_LT(keyframe_ate.rmse_m, 0.02);
  EXPECT_LT(frame_ate.rmse_m, 0.03);
}

// A place truly left and revisited: the camera circles a textured room
// (render/room_loop.hpp) 1.2 times, looking outwards, so the start's map
// points leave the local map and monocular scale drift builds up until the
// start comes back into view. Loop closing must find that place again (the
// matched keyframe near the current one in the ground truth) and the
// corrected trajectory must be no worse than the one without loop closing.
// Both systems see the same frames, rendered once.
TEST(SlamLoop, CirclingARoomClosesAVerifiedLoop) {
  RoomLoopParams room;  // 500 frames, 1.2 turns, seed 1
  const std::vector<StampedPose> path = roomLoopPath(room);
  RoomLoopRenderer renderer(room);

  SystemOptions options;
  options.deterministic = true;
  Config config;
  config.camera = room.camera;
  config.detector.model = "none";
  config.loop.final_ba = false;  // compare loop closing alone
  System with_loop(config, options);
  config.loop.enabled = false;
  System without_loop(config, options);
  for (size_t k = 0; k < path.size(); ++k) {
    const cv::Mat image = renderer.render(path[k].T_wc);
    with_loop.processFrame(static_cast<int>(k), path[k].timestamp, image);
    without_loop.processFrame(static_cast<int>(k), path[k].timestamp, image);
  }
  with_loop.finish();
  without_loop.finish();

  EXPECT_GE(with_loop.stats().frames_tracked, 0.97 * room.frames);
  EXPECT_TRUE(without_loop.loops().empty());
  const std::vector<LoopRecord> loops = with_loop.loops();
  ASSERT_GE(loops.size(), 1u);
  std::map<long, int> frame_of;
  for (const ExportedKeyFrame& keyframe : with_loop.keyFrames()) frame_of[keyframe.id] = keyframe.frame_index;
  for (const LoopRecord& loop : loops) {
    EXPECT_GE(loop.inliers, 40);
    EXPECT_GT(loop.scale, 0.8);  // the drift the loop undoes: a few per cent
    EXPECT_LT(loop.scale, 1.25);
    // Same place: the current keyframe is on the second turn, the matched one
    // on the first, and in the ground truth they are close and look the same way.
    ASSERT_TRUE(frame_of.count(loop.current_keyframe) && frame_of.count(loop.matched_keyframe));
    const SE3& current = path[frame_of[loop.current_keyframe]].T_wc;
    const SE3& matched = path[frame_of[loop.matched_keyframe]].T_wc;
    EXPECT_GT(frame_of[loop.current_keyframe], room.frames / room.turns);
    EXPECT_LT((current.t - matched.t).norm(), 0.3);
    EXPECT_GT(current.R.col(2).dot(matched.R.col(2)), std::cos(30.0 * M_PI / 180.0));
  }

  const AteResult ate_with = ate(with_loop.keyframeTrajectory(), path);
  const AteResult ate_without = ate(without_loop.keyframeTrajectory(), path);
  EXPECT_LE(ate_with.rmse_m, ate_without.rmse_m) << "with " << ate_with.rmse_m << ", without " << ate_without.rmse_m;
  // The room is 6 m wide; measured 0.92 cm with loop closing, 2.5 cm without.
  EXPECT_LT(ate_with.rmse_m, 0.015);
}

// The room circled fast (1.1 turns in 200 frames, 0.8 m/s), monocular and
// threaded. The map starts from frames 0 and 2 at 1.3 deg of parallax, and the
// first keyframes after it change the young map's scale by a factor of 2-5.
// The frames tracked in between kept their pose relative to their reference
// keyframe in the old scale: measured 4.7-5.3 cm frame ATE against 0.5-0.7 cm
// for the keyframes, growing linearly from each keyframe. Posed again against
// their matched points after the final BA, the frames follow the map:
// 1.1-1.3 cm.
TEST(SlamLoop, FramesFollowTheFinalMap) {
  RoomLoopParams room;
  room.frames = 200;
  room.turns = 1.1;
  const std::vector<StampedPose> path = roomLoopPath(room);
  RoomLoopRenderer renderer(room);
  Config config;
  config.camera = room.camera;
  config.detector.model = "none";
  System system(config, SystemOptions());
  test::feedRoom(system, renderer, path);
  system.finish();
  ASSERT_GE(system.stats().frames_tracked, 190);
  const double keyframes = ate(system.keyframeTrajectory(), path).rmse_m;
  const double frames = ate(system.frameTrajectory(), path).rmse_m;
  const double frames_before = ate(system.frameTrajectoryBeforeFinalBa(), path).rmse_m;
  std::printf("keyframe ATE %.4f m, frame ATE %.4f m (before the final BA %.4f m)\n", keyframes, frames,
              frames_before);
  EXPECT_LT(keyframes, 0.015);
  EXPECT_LT(frames, 0.025);
  EXPECT_LT(frames, 0.5 * frames_before);
}

TEST(SlamLoop, FinalBundleAdjustmentDoesNotWorsenTheTrajectory) {
  const Sequence sequence = fr1Xyz();
  SystemOptions options;
  options.deterministic = true;
  Config config = sequence.config;
  config.detector.model = "none";
  System system(config, options);
  for (size_t i = 0; i < 150; ++i)
    system.processFrame(sequence.frames[i].index, sequence.frames[i].timestamp, sequence.loadColor(i));
  system.finish();
  ASSERT_FALSE(system.keyframeTrajectoryBeforeFinalBa().empty());
  const double before = ate(system.keyframeTrajectoryBeforeFinalBa(), sequence.groundtruth).rmse_m;
  const double after = ate(system.keyframeTrajectory(), sequence.groundtruth).rmse_m;
  EXPECT_LE(after, before * 1.05) << "before " << before << ", after " << after;
  EXPECT_LT(after, 0.02);
}

TEST(SlamLoop, MissingVocabularyIsAnInputError) {
  Config config;
  config.detector.model = "none";
  config.loop.vocabulary = (test::scratchDir("SlamLoop_MissingVocabulary") / "nope.bin").string();
  SystemOptions options;
  options.deterministic = true;
  try {
    System system(config, options);
    FAIL() << "expected an InputError";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("nope.bin"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace vslam

namespace vslam {
namespace {

// tools/setup.sh trains the default where the training images are, as in
// ../shared, which the tests need anyway (test_support.hpp): here it must be built.
TEST(SlamLoop, DefaultVocabularyResolvesFromTheProjectRootAndLoads) {
  const std::filesystem::path previous = std::filesystem::current_path();
  std::filesystem::current_path(test::scratchDir("SlamLoop_DefaultVocabulary"));
  const std::string resolved = resolveVocabularyPath(LoopParams{}.vocabulary);
  std::filesystem::current_path(previous);
  EXPECT_EQ(std::filesystem::path(resolved), test::sourceDir() / "vocab" / "orbvoc_k10_L6.bin")
      << "tools/setup.sh (tools/build_vocab.sh) did not build the default vocabulary";
  const Vocabulary vocabulary = Vocabulary::load(resolved);
  EXPECT_EQ(vocabulary.branching(), 10);
  EXPECT_EQ(vocabulary.depth(), 6);  // ORB-SLAM's shape
  EXPECT_EQ(vocabulary.wordCount(), 456058u);  // vocab/README.md
  // A path that exists nowhere is returned as given, for the loader to report.
  EXPECT_EQ(resolveVocabularyPath("no/such/vocab.bin"), "no/such/vocab.bin");
}

TEST(SlamLoop, CommittedVocabularyIsKTenLFive) {
  const Vocabulary vocabulary = Vocabulary::load((test::sourceDir() / LoopParams::kFallbackVocabulary).string());
  EXPECT_EQ(vocabulary.branching(), 10);
  EXPECT_EQ(vocabulary.depth(), 5);
  EXPECT_EQ(vocabulary.wordCount(), 96326u);  // vocab/README.md
}

// Where the default could not be trained, it resolves to the committed L = 5
// file; any other missing path stays missing, for the loader to report.
TEST(SlamLoop, DefaultVocabularyFallsBackToTheCommittedOneOnlyWhenNotBuilt) {
  const std::filesystem::path root = test::scratchDir("SlamLoop_VocabularyFallback");
  const std::filesystem::path previous = std::filesystem::current_path();
  std::filesystem::current_path(test::scratchDir("SlamLoop_VocabularyFallback_cwd"));
  std::filesystem::create_directories(root / "vocab");
  std::ofstream(root / LoopParams::kFallbackVocabulary) << "L5";
  const std::string without_default = resolveVocabularyPath(LoopParams::kDefaultVocabulary, root.string());
  const std::string other_missing = resolveVocabularyPath("vocab/other.bin", root.string());
  std::ofstream(root / LoopParams::kDefaultVocabulary) << "L6";
  const std::string with_default = resolveVocabularyPath(LoopParams::kDefaultVocabulary, root.string());
  const std::string fallback_asked = resolveVocabularyPath(LoopParams::kFallbackVocabulary, root.string());
  std::filesystem::current_path(previous);
  EXPECT_EQ(std::filesystem::path(without_default), root / LoopParams::kFallbackVocabulary);
  EXPECT_EQ(other_missing, "vocab/other.bin");
  EXPECT_EQ(std::filesystem::path(with_default), root / LoopParams::kDefaultVocabulary);
  EXPECT_EQ(std::filesystem::path(fallback_asked), root / LoopParams::kFallbackVocabulary);
}

}  // namespace
}  // namespace vslam
