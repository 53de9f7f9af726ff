// Threaded runs, as users run them (the default of `vslam run`): Local Mapping
// and Loop Closing on their own threads, Tracking waiting for Local Mapping
// rather than dropping a keyframe. The accuracy bounds come from repeated
// threaded runs on this machine kind (docs/BENCHMARKS.md, "Threaded against
// deterministic"), with a margin for run-to-run spread.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>

#include <gtest/gtest.h>

#include "sequence_test_support.hpp"
#include "test_support.hpp"
#include "vslam/eval/ate.hpp"
#include "vslam/io/sequence.hpp"
#include "vslam/render/room_loop.hpp"
#include "vslam/slam/loop_closing.hpp"
#include "vslam/slam/system.hpp"

namespace vslam {
namespace {

double ateRmse(const std::vector<StampedPose>& estimate, const std::vector<StampedPose>& groundtruth) {
  AteOptions options;
  options.alignment = Alignment::Sim3;
  return computeAte(estimate, groundtruth, options).rmse_m;
}

Config withoutDetector(Config config) {
  config.detector.model = "none";
  return config;
}

// The whole of fr1_xyz, threaded: deterministic runs track 796 of 798 frames
// with a keyframe ATE of 0.9 cm; threaded runs must do as well within noise.
TEST(SlamThreaded, Fr1XyzWholeSequenceTracksAccurately) {
  const Sequence sequence = test::openSharedSequence("tum/fr1_xyz");
  System system(withoutDetector(sequence.config), SystemOptions{});
  for (size_t i = 0; i < sequence.frames.size(); ++i)
    system.processFrame(sequence.frames[i].index, sequence.frames[i].timestamp, sequence.loadColor(i));
  system.finish();
  const SystemStats stats = system.stats();
  EXPECT_GE(stats.frames_tracked, 790);
  EXPECT_EQ(stats.map_resets, 0);
  const double keyframe_ate = ateRmse(system.keyframeTrajectory(), sequence.groundtruth);
  const double frame_ate = ateRmse(system.frameTrajectory(), sequence.groundtruth);
  EXPECT_LT(keyframe_ate, 0.0125) << "keyframe ATE " << keyframe_ate;
  EXPECT_LT(frame_ate, 0.02) << "frame ATE " << frame_ate;
  EXPECT_TRUE(system.loops().empty()) << "fr1_xyz never leaves its local map: a loop closed there is false";
}

// The first 200 frames of KITTI 00 drive down one street and never come back:
// no loop may be closed. Issue 18's bounds hold too: at least 98 % of the
// frames tracked, keyframe ATE (Sim(3)) at most 0.6 m. Threaded runs track 199
// of 200 at 0.380 m since the road configs triangulate against the keyframes
// before (0.705 m before; docs/BENCHMARKS.md, "Triangulation with the
// keyframes before").
TEST(SlamThreaded, KittiRoadClosesNoFalseLoopAndMeetsIssue18sBounds) {
  const Sequence sequence = test::openSharedSequence("kitti/00");
  System system(withoutDetector(sequence.config), SystemOptions{});
  for (size_t i = 0; i < sequence.frames.size() && i < 200; ++i)
    system.processFrame(sequence.frames[i].index, sequence.frames[i].timestamp, sequence.loadColor(i));
  system.finish();
  EXPECT_GE(system.stats().frames_tracked, 196);
  EXPECT_TRUE(system.loops().empty());
  const double keyframe_ate = ateRmse(system.keyframeTrajectory(), sequence.groundtruth);
  EXPECT_LT(keyframe_ate, 0.6) << "keyframe ATE " << keyframe_ate;
}

struct RoomRun {
  int frames_tracked = 0;
  std::vector<LoopRecord> loops;
  std::map<long, int> frame_of_keyframe;
  double keyframe_ate = 0;
};

// The synthetic room loop, threaded, `runs` times over the same frames.
std::vector<RoomRun> runRoomLoopThreaded(const RoomLoopParams& room, const std::vector<StampedPose>& path, int runs) {
  std::vector<cv::Mat> images;
  {
    RoomLoopRenderer renderer(room);
    for (const StampedPose& pose : path) images.push_back(renderer.render(pose.T_wc).clone());
  }
  Config config;
  config.camera = room.camera;
  config.detector.model = "none";
  config.loop.final_ba = false;  // loop closing's own correction is what is checked
  std::vector<RoomRun> results;
  for (int run = 0; run < runs; ++run) {
    System system(config, SystemOptions{});
    for (size_t k = 0; k < path.size(); ++k) system.processFrame(static_cast<int>(k), path[k].timestamp, images[k]);
    system.finish();
    RoomRun result;
    result.frames_tracked = system.stats().frames_tracked;
    result.loops = system.loops();
    for (const ExportedKeyFrame& keyframe : system.keyFrames()) result.frame_of_keyframe[keyframe.id] = keyframe.frame_index;
    result.keyframe_ate = ateRmse(system.keyframeTrajectory(), path);
    results.push_back(result);
  }
  return results;
}

// Loop closing, keyframe culling and the full-BA merge, threaded, twice over
// the same frames (a stress test for the threads' sharing of the map): each
// run must track the room and close a verified loop between the same places.
TEST(SlamThreaded, CirclingARoomClosesAVerifiedLoopEveryRun) {
  RoomLoopParams room;  // 500 frames, 1.2 turns, seed 1
  const std::vector<StampedPose> path = roomLoopPath(room);
  const std::vector<RoomRun> runs = runRoomLoopThreaded(room, path, 2);
  for (size_t run = 0; run < runs.size(); ++run) {
    EXPECT_GE(runs[run].frames_tracked, 0.97 * room.frames) << "run " << run;
    ASSERT_GE(runs[run].loops.size(), 1u) << "run " << run;
    std::map<long, int> frame_of = runs[run].frame_of_keyframe;
    for (const LoopRecord& loop : runs[run].loops) {
      EXPECT_GE(loop.inliers, 40);
      EXPECT_GT(loop.scale, 0.8);
      EXPECT_LT(loop.scale, 1.25);
      ASSERT_TRUE(frame_of.count(loop.current_keyframe) && frame_of.count(loop.matched_keyframe));
      const SE3& current = path[frame_of[loop.current_keyframe]].T_wc;
      const SE3& matched = path[frame_of[loop.matched_keyframe]].T_wc;
      EXPECT_LT((current.t - matched.t).norm(), 0.3) << "run " << run;
    }
  }
}

// Issue 16: the loop closes for every texture seed 1-10, threaded, between
// keyframes the ground truth places within 0.3 m of each other, and no other
// loop is closed (tools/bench_room_seeds.sh prints the same runs' figures).
class SlamThreadedRoomSeed : public ::testing::TestWithParam<unsigned> {};

TEST_P(SlamThreadedRoomSeed, ClosesOneTrueLoop) {
  RoomLoopParams room;
  room.seed = GetParam();
  const std::vector<StampedPose> path = roomLoopPath(room);
  const RoomRun run = runRoomLoopThreaded(room, path, 1).front();
  EXPECT_GE(run.frames_tracked, 0.97 * room.frames);
  ASSERT_EQ(run.loops.size(), 1u);
  const LoopRecord& loop = run.loops.front();
  ASSERT_TRUE(run.frame_of_keyframe.count(loop.current_keyframe) && run.frame_of_keyframe.count(loop.matched_keyframe));
  const SE3& current = path[run.frame_of_keyframe.at(loop.current_keyframe)].T_wc;
  const SE3& matched = path[run.frame_of_keyframe.at(loop.matched_keyframe)].T_wc;
  std::printf("seed %u: loop %ld-%ld, %.3f m apart in the ground truth, keyframe ATE %.2f cm\n", room.seed,
              loop.current_keyframe, loop.matched_keyframe, (current.t - matched.t).norm(), 100 * run.keyframe_ate);
  EXPECT_LT((current.t - matched.t).norm(), 0.3);
}

INSTANTIATE_TEST_SUITE_P(Seeds1To10, SlamThreadedRoomSeed, ::testing::Range(1u, 11u));

// The room loop's accuracy, threaded. At 4525ce0 threaded runs gave keyframe
// ATE 0.43-2.4 cm and once 17.7 cm on a loaded machine (deterministic: 0.9 cm).
// Since Local Mapping pauses only with its queue drained and Tracking waits for
// the mapping of weak-tracking keyframes, 15 threaded runs at 42d545b, under a
// load average of 7-9.5 (stress-ng and parallel builds), all gave 0.56-0.57 cm
// with the same loop (docs/BENCHMARKS.md): the bound is that with a margin.
TEST(SlamThreaded, CirclingARoomKeepsItsAccuracy) {
  RoomLoopParams room;
  const std::vector<StampedPose> path = roomLoopPath(room);
  for (const RoomRun& run : runRoomLoopThreaded(room, path, 2)) {
    // The figure docs/BENCHMARKS.md gathers with --gtest_repeat.
    std::printf("room loop, threaded: keyframe ATE %.2f cm, %zu loop(s)\n", 100 * run.keyframe_ate, run.loops.size());
    EXPECT_EQ(run.loops.size(), 1u);
    EXPECT_LT(run.keyframe_ate, 0.010) << "keyframe ATE " << run.keyframe_ate;
  }
}

// Regression: a map reset after early loss left Loop Closing with the old
// map's queued ids and consistency groups, and the last frame with pointers
// into the freed map. Here tracking is lost one frame after initialisation
// (frames of another scene), while the map holds at most 3 keyframes (a weak
// start makes a keyframe of every frame after it), the map is reset, and the
// run goes on to initialise again and track the rest.
TEST(SlamThreaded, ResetAfterEarlyLossLeavesLoopClosingCleanAndReinitialises) {
  const Sequence xyz = test::openSharedSequence("tum/fr1_xyz");
  const Sequence teddy = test::openSharedSequence("tum/fr3_teddy");
  System system(withoutDetector(xyz.config), SystemOptions{});
  size_t next = 0;
  while (next < 40 && system.stats().initialised_at_index < 0) {
    system.processFrame(xyz.frames[next].index, xyz.frames[next].timestamp, xyz.loadColor(next));
    ++next;
  }
  ASSERT_GE(system.stats().initialised_at_index, 0);
  system.processFrame(xyz.frames[next].index, xyz.frames[next].timestamp, xyz.loadColor(next));
  ++next;
  // Another scene: nothing matches the map, which is only a few keyframes old.
  double t = xyz.frames[next].timestamp;
  for (size_t k = 0; k < 5 && system.stats().map_resets == 0; ++k)
    system.processFrame(-1, t += 0.001, teddy.loadColor(k * 30));
  ASSERT_EQ(system.stats().map_resets, 1);
  const LoopClosingState after_reset = system.loopClosingState();
  EXPECT_EQ(after_reset.queued, 0u);
  EXPECT_EQ(after_reset.consistent_groups, 0u);
  EXPECT_EQ(after_reset.last_loop_keyframe_id, -1);
  EXPECT_FALSE(after_reset.full_ba_running);
  EXPECT_EQ(system.stats().keyframes, 0);

  const size_t restart = next;
  for (; next < restart + 150; ++next)
    system.processFrame(xyz.frames[next].index, xyz.frames[next].timestamp, xyz.loadColor(next));
  system.finish();
  const SystemStats stats = system.stats();
  EXPECT_EQ(stats.map_resets, 1);
  EXPECT_GE(stats.initialised_at_index, static_cast<int>(restart));
  EXPECT_LE(stats.initialised_at_index, static_cast<int>(restart) + 30);
  const std::vector<StampedPose> trajectory = system.frameTrajectory();
  EXPECT_GE(trajectory.size(), 110u);
  EXPECT_LT(ateRmse(system.keyframeTrajectory(), xyz.groundtruth), 0.03);
}

// Regression: an exception on the Local Mapping thread ended in std::terminate.
// It must reach the caller as one error that names the thread.
TEST(SlamThreaded, LocalMappingFailureReachesTheCaller) {
  const Sequence sequence = test::openSharedSequence("tum/fr1_xyz");
  SystemOptions options;
  options.after_keyframe_mapped = [](long id) {
    if (id == 3) throw std::runtime_error("injected failure at keyframe 3");
  };
  System system(withoutDetector(sequence.config), options);
  std::string error;
  try {
    for (size_t i = 0; i < 300; ++i)
      system.processFrame(sequence.frames[i].index, sequence.frames[i].timestamp, sequence.loadColor(i));
    system.finish();
  } catch (const std::runtime_error& e) {
    error = e.what();
  }
  EXPECT_NE(error.find("local mapping"), std::string::npos) << error;
  EXPECT_NE(error.find("injected failure at keyframe 3"), std::string::npos) << error;
}

}  // namespace
}  // namespace vslam
