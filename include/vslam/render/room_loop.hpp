#pragma once
// A synthetic sequence with a true loop: a camera circles inside a closed box
// room, drawn off-screen through OSMesa, and comes back to where it started.
// Every wall, floor and ceiling panel carries its own procedurally drawn
// texture (seeded), so no two places look alike and the revisit is the only
// loop there is. The camera looks outwards, away from the room's centre, so
// the start leaves the view for most of the turn: tracking cannot hold on to
// the first map points, monocular drift accumulates, and the loop has to be
// found by place recognition. Everything here is deterministic.
//
// World frame: x and z horizontal, y down (like an upright camera's y), the
// room centred on the origin. Poses are camera-to-world, as on disk.
#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/core/camera.hpp"
#include "vslam/core/types.hpp"

namespace vslam {

struct RoomLoopParams {
  PinholeCamera camera = defaultCamera();
  double room_half_width_m = 3.0;  // walls at x = +-this and z = +-this
  double ceiling_y_m = -1.4;       // y is down: the ceiling is above the camera
  double floor_y_m = 1.2;
  int panels_per_wall = 3;         // each wall is split into this many textured panels
  int texture_px = 512;
  double path_radius_m = 0.8;      // the camera's circle around the room's centre
  double bob_m = 0.05;             // the camera also rises and falls by this much, twice per turn
  double turns = 1.2;              // more than one, so the start is seen again
  int frames = 500;
  double start_time_s = 0.0;
  unsigned seed = 1;

  // Optional moving object: a billboard showing this image (e.g. a photo of
  // a person) that walks through the camera's view, for testing how SLAM
  // copes with things that move. Empty: the room is static.
  std::string moving_object_image;
  double moving_object_width_m = 0.75;   // the billboard's height follows the image's aspect ratio
  double moving_object_radius_m = 1.9;    // distance from the room's centre (the camera circles at path_radius_m)
  int moving_object_first_frame = 60;     // it enters the view on this frame ...
  int moving_object_frames = 150;         // ... and crosses it in this many frames
  double moving_object_sweep_deg = 50.0;  // its bearing from the camera goes from +half to -half of this

  static PinholeCamera defaultCamera();
};

// The moving billboard's corners in the world at `frame` (texture corners
// (0,0), (1,0), (1,1), (0,1)), upright and facing the room's centre;
// `aspect` is its height over its width. It moves during its frames and
// stands still at its first or last place outside them (out of view there).
std::array<Vec3, 4> movingObjectCorners(const RoomLoopParams& params, int frame, double aspect);

// Ground truth: one camera-to-world pose per frame, timestamps at camera.fps.
std::vector<StampedPose> roomLoopPath(const RoomLoopParams& params);

class RoomLoopRenderer {
 public:
  // Builds the scene's textures and an off-screen context. Throws
  // std::runtime_error when OSMesa is unavailable.
  explicit RoomLoopRenderer(const RoomLoopParams& params);
  ~RoomLoopRenderer();
  RoomLoopRenderer(const RoomLoopRenderer&) = delete;
  RoomLoopRenderer& operator=(const RoomLoopRenderer&) = delete;

  // Places the moving object (if any) where it is at this frame; the views
  // below show it there. Frame 0 until called.
  void setFrame(int frame);

  // The view from camera-to-world pose T_wc: CV_8UC3 BGR, camera.width x camera.height.
  cv::Mat render(const SE3& T_wc);

  // The depth of the same view: CV_32F, camera.width x camera.height, each
  // pixel the camera z (along the optical axis, not the ray's length) in metres
  // of the surface at that pixel's centre, 0 where nothing was drawn. Drawn at
  // the camera's own resolution, not averaged down like the colour (an average
  // across a depth edge is a surface that is not there), so pixel (u, v) of
  // both images looks along the same ray.
  cv::Mat renderDepth(const SE3& T_wc);

 private:
  struct Scene;
  std::unique_ptr<Scene> scene_;
};

// Metric depth (CV_32F, metres) as a TUM depth image: CV_16UC1, value = metres
// times depth_factor, rounded; 0 where the depth is 0 or beyond 65535 units.
cv::Mat encodeTumDepth(const cv::Mat& depth_m, double depth_factor);

// Writes a TUM RGB-D folder: rgb/<timestamp>.png, depth/<timestamp>.png (the
// same timestamps, camera.depth_factor units per metre), rgb.txt, depth.txt,
// groundtruth.txt and camera.yaml (for `vslam run --seq FOLDER --config
// FOLDER/camera.yaml`). With a moving object, also moving_object.txt: per
// frame its timestamp and the world position of the billboard's centre.
// `progress` is called after each frame with (frames written, total).
void writeRoomLoopSequence(const RoomLoopParams& params, const std::string& folder,
                           const std::function<void(int, int)>& progress = {});

}  // namespace vslam
