// Mapping that continues in a saved map (issue 17): the camera circles a
// textured room (render/room_loop.hpp, 1.2 turns); a first System maps the
// first half and saves it, a second System loads that map and maps the second
// half into it. The second System relocalises in the loaded map, adds its own
// keyframes after the loaded ones, and closes the loop into the loaded part
// when the start of the circle comes back into view.
#include <cmath>
#include <map>

#include <gtest/gtest.h>

#include "system_test_support.hpp"
#include "test_support.hpp"
#include "vslam/eval/ate.hpp"
#include "vslam/map_io/map_database.hpp"
#include "vslam/render/room_loop.hpp"
#include "vslam/slam/loop_closing.hpp"
#include "vslam/slam/system.hpp"

namespace vslam {
namespace {

void continueTheRoomLoop(bool deterministic) {
  RoomLoopParams room;  // 500 frames, 1.2 turns, seed 1
  const std::vector<StampedPose> path = roomLoopPath(room);
  RoomLoopRenderer renderer(room);
  const size_t half = path.size() / 2;
  const std::string map_file =
      (test::scratchDir(deterministic ? "map_continue_room" : "map_continue_room_threaded") / "first_half.sqlite")
          .string();

  SystemOptions options;
  options.deterministic = deterministic;
  Config config;
  config.camera = room.camera;
  config.detector.model = "none";
  long loaded_last_keyframe = -1;
  {
    System first(config, options);
    test::feedRoom(first, renderer, path, false, 0, half);
    first.finish();
    ASSERT_GE(first.stats().frames_tracked, 0.97 * half);
    first.saveMap(map_file, "room loop, first half");
    for (const ExportedKeyFrame& keyframe : first.keyFrames())
      loaded_last_keyframe = std::max(loaded_last_keyframe, keyframe.id);
  }

  System second(config, options);
  const std::pair<int, int> loaded = second.loadMap(map_file, false);
  EXPECT_EQ(static_cast<size_t>(loaded.first), readMapCounts(map_file).keyframes);
  test::feedRoom(second, renderer, path, false, half);
  second.finish();

  const SystemStats stats = second.stats();
  EXPECT_GE(stats.frames_tracked, 0.97 * (path.size() - half));
  EXPECT_GT(stats.frames_in_loaded_map, 0);   // the first frames relocalise in the loaded map...
  EXPECT_GT(stats.keyframes, loaded.first);   // ...and mapping goes on from there
  std::map<long, int> frame_of;
  for (const ExportedKeyFrame& keyframe : second.keyFrames()) frame_of[keyframe.id] = keyframe.frame_index;
  const std::vector<LoopRecord> loops = second.loops();
  ASSERT_GE(loops.size(), 1u);
  bool closed_into_loaded_part = false;
  for (const LoopRecord& loop : loops) {
    ASSERT_TRUE(frame_of.count(loop.current_keyframe) && frame_of.count(loop.matched_keyframe));
    std::printf("loop: keyframe %ld (frame %d) with keyframe %ld (frame %d), scale %.3f, %d inliers\n",
                loop.current_keyframe, frame_of[loop.current_keyframe], loop.matched_keyframe,
                frame_of[loop.matched_keyframe], loop.scale, loop.inliers);
    EXPECT_GT(loop.current_keyframe, loaded_last_keyframe);  // made in this run
    const SE3& current = path[frame_of[loop.current_keyframe]].T_wc;
    const SE3& matched = path[frame_of[loop.matched_keyframe]].T_wc;
    EXPECT_LT((current.t - matched.t).norm(), 0.3);  // the same place in the ground truth
    if (loop.matched_keyframe <= loaded_last_keyframe) closed_into_loaded_part = true;
  }
  EXPECT_TRUE(closed_into_loaded_part);
  AteOptions ate_options;
  ate_options.alignment = Alignment::Sim3;
  const AteResult ate = computeAte(second.keyframeTrajectory(), path, ate_options);
  std::printf("keyframe ATE of the whole map after continuing: %.4f m (%zu keyframes)\n", ate.rmse_m,
              second.keyframeTrajectory().size());
  EXPECT_LT(ate.rmse_m, 0.03);  // the room is 6 m wide
}

TEST(MapContinue, SecondHalfOfTheRoomLoopIsMappedIntoTheFirstAndClosesTheLoop) { continueTheRoomLoop(true); }

// As `vslam run` runs by default: Tracking, Local Mapping and Loop Closing on their own threads.
TEST(MapContinue, SecondHalfOfTheRoomLoopIsMappedIntoTheFirstAndClosesTheLoopThreaded) {
  continueTheRoomLoop(false);
}

}  // namespace
}  // namespace vslam
