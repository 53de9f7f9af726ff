#pragma once
// Map figures for reports: the point cloud coloured by image colour or by
// object class, keyframes as small camera frusta, object boxes with labels.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/core/types.hpp"
#include "vslam/render/plot_projection.hpp"

namespace vslam {

struct MapRenderPoint {
  Vec3 position;
  cv::Vec3b bgr;
  int class_id = -1;  // COCO index; -1 = not on a detected object
};

struct MapRenderKeyframe {
  SE3 T_wc;  // camera-to-world (camera looks along its +z, x right, y down)
};

struct MapRenderObject {
  std::string label;  // drawn as is, e.g. "car" or "car 0.91"
  int class_id = -1;
  Vec3 box_min, box_max;  // axis-aligned in the world frame
};

struct MapRenderInput {
  std::string title;
  std::vector<MapRenderPoint> points;
  std::vector<MapRenderKeyframe> keyframes;
  std::vector<MapRenderObject> objects;
  std::vector<Vec3> trajectory;  // camera positions, drawn as a thin line
};

enum class MapColouring { ImageColour, ObjectClass };

// The view is fitted to the trajectory, keyframes, objects and the central
// 96 % of the points along each axis (stray far points are drawn, not fitted).
// `used_projection`, when given, receives the world -> pixel transform.
cv::Mat renderMap(const MapRenderInput& input, MapColouring colouring, PlotView view, cv::Size size = {1280, 960},
                  PlotProjection* used_projection = nullptr);

// Writes out_dir/map_colour.png and map_classes.png (perspective views) and
// map_top.png (top view, class colours). Throws std::runtime_error naming the
// file when writing fails.
void writeMapRenders(const MapRenderInput& input, const std::string& out_dir);

// Deterministic colour (BGR) of a COCO class: 80 distinct, saturated colours
// (ids >= 80 wrap round); class_id < 0 gives the light grey of unlabelled points.
cv::Scalar classColour(int class_id);

// COCO's name for class_id 0..79, "class <id>" otherwise.
std::string cocoClassName(int class_id);
// Inverse of cocoClassName for the 80 COCO names; -1 when unknown.
int cocoClassId(const std::string& name);

}  // namespace vslam
