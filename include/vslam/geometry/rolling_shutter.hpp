#pragma once
// A rolling-shutter camera (the Kinect's and the Xtion's colour cameras)
// exposes its rows one after another: row y is seen
// rowTime(y) = (y / height - 1/2) * readout_s after the middle row, and a
// moving camera has moved meanwhile. A pose solved from a whole frame as if
// every row were seen at once lands near the middle row's pose, bent by that
// motion. Posing a frame at its middle row, each observation is corrected by
// the camera's motion over its row's time, with the velocity taken from the
// neighbouring frames' poses (docs/GEOMETRY.md, "Rolling shutter").
#include "vslam/core/types.hpp"

namespace vslam {

// The camera's motion per second, in its own coordinates: a point fixed in
// the world, at p in the camera now, is at Exp(dt * angular) p + dt * linear
// dt seconds later (to first order in dt for a general motion; exactly for
// the motion velocityBetween measured, over its own dt).
struct CameraVelocity {
  Vec3 angular = Vec3::Zero();  // rotation vector per second
  Vec3 linear = Vec3::Zero();   // map units per second
};

// The constant velocity that takes pose T_cw_before to T_cw_after in dt > 0 seconds.
CameraVelocity velocityBetween(const SE3& T_cw_before, const SE3& T_cw_after, double dt);

// The camera's own motion over row_time seconds: a point fixed in the world,
// at p in the camera at the middle row's time, is at motionOverRowTime(...) * p
// in the camera when row_time later it exposes another row.
SE3 motionOverRowTime(const CameraVelocity& velocity, double row_time);

// Seconds from the middle row's exposure to row y's (negative above the middle).
inline double rowTime(double y, int height, double readout_s) { return (y / height - 0.5) * readout_s; }

// Where a world point would have to be for the camera at T_cw (the middle
// row's pose) to see it where the moving camera saw point_w, row_time seconds
// later: T_cw of the result is the point as the camera held it then.
Vec3 pointSeenAtRowTime(const SE3& T_cw, const Vec3& point_w, const CameraVelocity& velocity, double row_time);

}  // namespace vslam
