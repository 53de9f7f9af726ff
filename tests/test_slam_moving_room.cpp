// Issue 15's synthetic check of moving-object handling: the room with a
// billboard of a person (cropped from ../shared's person.jpg) walking across
// the view, which the detector sees as a person. With the motion check of
// --moving-classes the run stays within 1.2x the static room's keyframe ATE;
// with the paper's filter alone (keypoints added on the person, no check) it
// does not. Threaded, with detection submitted ahead, as `vslam run` runs.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "test_support.hpp"
#include "vslam/core/config.hpp"
#include "vslam/eval/ate.hpp"
#include "vslam/render/room_loop.hpp"
#include "vslam/slam/system.hpp"

namespace vslam {
namespace {

// The billboard crosses the view during frames 60-210; 260 frames at the
// default speed (1.2 turns in 500 frames) cover it and 50 frames after.
RoomLoopParams shortRoom() {
  RoomLoopParams room;
  room.frames = 260;
  room.turns = 1.2 * room.frames / 500.0;
  return room;
}

// The person cropped from the photo (x 165-305, y 80-390 of the 640x424
// photo): a billboard of the whole photo would show a landscape that no box
// marks as movable. The crop is still wider than the detector's person box
// (x 188-272, y 103-363 on the photo): in the room, about 40 % of the
// billboard's pixels (grass, the dog's head) fall outside the boxes
// (tools/billboard_coverage.py: 41 % on texture seeds 1 and 6) and are
// keypoints of the static scene to the check, moving with the person
// (docs/BENCHMARKS.md, "What the billboard is").
std::string croppedPerson() {
  const cv::Mat photo = cv::imread((test::sharedData() / "images/person.jpg").string(), cv::IMREAD_COLOR);
  if (photo.empty()) return "";
  const std::string path = (test::scratchDir("moving_room") / "person.png").string();
  cv::imwrite(path, photo(cv::Rect(165, 80, 140, 310)));
  return path;
}

struct RoomRun {
  AteResult keyframes;
  SystemStats stats;
};

RoomRun runRoom(const RoomLoopParams& room, const std::vector<std::string>& moving_classes) {
  const std::vector<StampedPose> path = roomLoopPath(room);
  RoomLoopRenderer renderer(room);
  auto render = [&](size_t k) {
    renderer.setFrame(static_cast<int>(k));  // where the billboard is at frame k
    return renderer.render(path[k].T_wc);
  };

  Config config;
  config.camera = room.camera;
  config.detector.moving_classes = moving_classes;
  System system(config, SystemOptions());
  // Each frame rendered once, the next one ahead for detection, as `vslam run` reads them.
  cv::Mat image = render(0);
  for (size_t k = 0; k < path.size(); ++k) {
    cv::Mat next;
    if (k + 1 < path.size()) {
      next = render(k + 1);
      system.submitAhead(static_cast<int>(k + 1), next);
    }
    system.processFrame(static_cast<int>(k), path[k].timestamp, image);
    image = next;
  }
  system.finish();
  EXPECT_GE(system.stats().frames_tracked, static_cast<int>(path.size()) - 5);
  AteOptions sim3;
  sim3.alignment = Alignment::Sim3;  // monocular
  return {computeAte(system.keyframeTrajectory(), path, sim3), system.stats()};
}

TEST(SlamMovingObject, RoomWithAWalkingPersonStaysNearTheStaticRoomOnlyWithMotionChecks) {
  RoomLoopParams room = shortRoom();
  const RoomRun static_room = runRoom(room, {"coco-movable"});
  room.moving_object_image = croppedPerson();
  ASSERT_FALSE(room.moving_object_image.empty()) << "../shared/data/images/person.jpg is missing";
  room.moving_object_width_m = 0.35;
  const RoomRun checked = runRoom(room, {"coco-movable"});
  const RoomRun unchecked = runRoom(room, {});
  std::printf("keyframe ATE: static room %.4f m; walking person, motion checks %.4f m (%d box-frames moving), "
              "paper's filter alone %.4f m\n",
              static_room.keyframes.rmse_m, checked.keyframes.rmse_m, checked.stats.moving_boxes_moving,
              unchecked.keyframes.rmse_m);
  EXPECT_EQ(static_room.stats.moving_boxes_checked, 0);  // no person in the static room
  EXPECT_GT(checked.stats.moving_boxes_moving, 0);             // the person is seen moving
  // Measured (threaded, 3 runs each, 2 Dec 2026): static 0.89-0.90 cm, checked
  // 1.03 cm (1.15x), paper's filter alone 1.65 cm (1.85x).
  // Fragile: both conditions hold on 3 of 8 texture seeds, and a tighter pose
  // solver tolerance makes seed 1 fail too (tools/bench_moving_room.sh;
  // docs/BENCHMARKS.md, "The moving-room test across texture seeds").
  EXPECT_LE(checked.keyframes.rmse_m, 1.2 * static_room.keyframes.rmse_m);
  EXPECT_GT(unchecked.keyframes.rmse_m, 1.2 * static_room.keyframes.rmse_m);
}

}  // namespace
}  // namespace vslam
