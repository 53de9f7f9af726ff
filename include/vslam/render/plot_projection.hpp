#pragma once
// The view transform shared by the GL pass and the OpenCV text pass of every
// render, and the small rules (tick steps, plane choice) behind the axes.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/core/types.hpp"

namespace vslam {

// Top: orthographic, equal axis scale, looking down the axis along which the
// scene spreads least (see chooseTopPlane). Perspective: a fixed camera ~35°
// above that plane, off to one side, looking at the scene's bounding box.
enum class PlotView { Top, Perspective };

// The plane a top view shows: horizontal image axis = world axis `right`,
// vertical image axis (upwards) = world axis `up_in_image`, seen from the
// side of their cross product `toward_viewer` (a unit world axis, possibly
// negative), so the view is never mirrored.
struct TopPlane {
  int right = 0;        // 0 = x, 1 = y, 2 = z
  int up_in_image = 1;
  Vec3 toward_viewer = Vec3::UnitZ();
};

// Drops the axis with the smallest extent over `points` (ties: the higher
// index, so a flat x-y scene gives x-y seen from +z; KITTI's x-z road plane
// gives x right, z up, seen from -y, i.e. from above since KITTI's y points down).
TopPlane chooseTopPlane(const std::vector<Vec3>& points);

// world -> pixel. One 4x4 matrix (view and projection together, GL's
// column-major convention) is loaded into GL as the projection matrix and used
// by toPixel, so text placed with it lands exactly on the rendered geometry.
struct PlotProjection {
  Mat4 world_to_clip = Mat4::Identity();
  cv::Size image_size;
  TopPlane plane;  // the scene's plane (top view: the one shown; perspective: the ground)
  // Top view: the middle of the scene along plane.toward_viewer, a depth
  // inside the clip volume for flat things such as the grid.
  double plane_level = 0.0;

  // OpenCV pixel coordinates (x right, y down, pixel centres at integers).
  cv::Point2d toPixel(const Vec3& world) const;
  // False for points behind a perspective camera (toPixel is meaningless there).
  bool inFront(const Vec3& world) const;
};

// The pixel rectangle the data is fitted into, leaving room for the title,
// tick labels, colour bar and legend.
struct PlotMargins {
  int left = 95, right = 200, top = 100, bottom = 80;
};

// Orthographic top view of `points` fitted into the plot area with equal
// metres-per-pixel on both axes (the tighter axis fills the area; padded 6 %).
PlotProjection fitTopView(const std::vector<Vec3>& points, cv::Size image_size, const PlotMargins& margins = {});

// Perspective view: eye 35° above the ground plane and 30° round from its
// -up_in_image side, at twice the bounding radius; the frustum is then made
// off-axis so the projection of `points` exactly fills the plot area.
PlotProjection fitPerspectiveView(const std::vector<Vec3>& points, cv::Size image_size,
                                  const PlotMargins& margins = {});

// A "nice" tick step (1, 2 or 5 times a power of ten) giving about
// `target_ticks` intervals over `range`. range <= 0 gives 1.
double niceTickStep(double range, int target_ticks = 6);

// The longest 1, 2 or 5 times a power of ten that is <= max_length (a scale
// bar that fits its space). max_length <= 0 gives 0.
double niceLengthAtMost(double max_length);

// Ticks k * step covering [low, high] (inclusive, with a little tolerance).
std::vector<double> ticksIn(double low, double high, double step);

// Label of a metre value with as many decimals as `step` needs ("0.25", "-1", "10").
std::string formatTick(double value_m, double step_m);

// Human length for a scale bar or grid spacing: "5 mm", "10 cm", "2 m", "1 km".
std::string formatLength(double metres);

}  // namespace vslam
