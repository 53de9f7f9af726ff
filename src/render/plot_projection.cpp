#include "vslam/render/plot_projection.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace vslam {
namespace {

struct Bounds {
  Vec3 min = Vec3::Constant(0.0);
  Vec3 max = Vec3::Constant(0.0);
  Vec3 centre() const { return 0.5 * (min + max); }
  Vec3 extent() const { return max - min; }
};

Bounds boundsOf(const std::vector<Vec3>& points) {
  Bounds bounds;
  if (points.empty()) return bounds;
  bounds.min = bounds.max = points.front();
  for (const Vec3& p : points) {
    bounds.min = bounds.min.cwiseMin(p);
    bounds.max = bounds.max.cwiseMax(p);
  }
  return bounds;
}

// A scene that is a single point or a line still needs a finite window.
constexpr double kMinimumSpanM = 0.05;

}  // namespace

TopPlane chooseTopPlane(const std::vector<Vec3>& points) {
  const Vec3 extent = boundsOf(points).extent();
  int dropped = 0;
  for (int axis = 1; axis < 3; ++axis)
    if (extent[axis] <= extent[dropped]) dropped = axis;
  TopPlane plane;
  plane.right = dropped == 0 ? 1 : 0;
  plane.up_in_image = dropped == 2 ? 1 : 2;
  plane.toward_viewer = Vec3::Unit(plane.right).cross(Vec3::Unit(plane.up_in_image));
  return plane;
}

cv::Point2d PlotProjection::toPixel(const Vec3& world) const {
  const Vec4 clip = world_to_clip * world.homogeneous();
  const double ndc_x = clip.x() / clip.w();
  const double ndc_y = clip.y() / clip.w();
  // GL's window coordinate u covers pixel floor(u); OpenCV puts pixel centres at integers.
  return {(ndc_x + 1.0) * 0.5 * image_size.width - 0.5, (1.0 - ndc_y) * 0.5 * image_size.height - 0.5};
}

bool PlotProjection::inFront(const Vec3& world) const {
  return (world_to_clip * world.homogeneous()).w() > 0.0;
}

PlotProjection fitTopView(const std::vector<Vec3>& points, cv::Size image_size, const PlotMargins& margins) {
  PlotProjection projection;
  projection.image_size = image_size;
  projection.plane = chooseTopPlane(points);
  const TopPlane& plane = projection.plane;
  const Bounds bounds = boundsOf(points);
  const Vec3 centre = bounds.centre();
  const Vec3 axis_right = Vec3::Unit(plane.right);
  const Vec3 axis_up = Vec3::Unit(plane.up_in_image);

  const double padding = 1.06;
  const double span_right = std::max(bounds.extent()[plane.right], kMinimumSpanM) * padding;
  const double span_up = std::max(bounds.extent()[plane.up_in_image], kMinimumSpanM) * padding;
  const double W = image_size.width, H = image_size.height;
  const double plot_w = W - margins.left - margins.right;
  const double plot_h = H - margins.top - margins.bottom;
  const double pixels_per_m = std::min(plot_w / span_right, plot_h / span_up);
  const double centre_u = margins.left + plot_w / 2.0;  // continuous pixel coordinates
  const double centre_v = margins.top + plot_h / 2.0;

  // Depth: nearer the viewer = smaller NDC z; generous so nothing is clipped.
  const double depth_half_range = 2.0 * std::max(bounds.extent().maxCoeff(), kMinimumSpanM);
  const double depth_centre = plane.toward_viewer.dot(centre);
  projection.plane_level = depth_centre;

  Mat4& m = projection.world_to_clip;
  m.setZero();
  m.block<1, 3>(0, 0) = (2.0 * pixels_per_m / W) * axis_right.transpose();
  m(0, 3) = (2.0 * centre_u / W - 1.0) - (2.0 * pixels_per_m / W) * axis_right.dot(centre);
  m.block<1, 3>(1, 0) = (2.0 * pixels_per_m / H) * axis_up.transpose();
  m(1, 3) = (1.0 - 2.0 * centre_v / H) - (2.0 * pixels_per_m / H) * axis_up.dot(centre);
  m.block<1, 3>(2, 0) = (-1.0 / depth_half_range) * plane.toward_viewer.transpose();
  m(2, 3) = depth_centre / depth_half_range;
  m(3, 3) = 1.0;
  return projection;
}

PlotProjection fitPerspectiveView(const std::vector<Vec3>& points, cv::Size image_size,
                                  const PlotMargins& margins) {
  PlotProjection projection;
  projection.image_size = image_size;
  projection.plane = chooseTopPlane(points);
  const TopPlane& plane = projection.plane;
  const Bounds bounds = boundsOf(points);
  const Vec3 centre = bounds.centre();
  const double radius = std::max(0.5 * bounds.extent().norm(), kMinimumSpanM);

  const double elevation = 35.0 * M_PI / 180.0;
  const double azimuth = 30.0 * M_PI / 180.0;
  const Vec3 up = plane.toward_viewer;
  const Vec3 ground_right = Vec3::Unit(plane.right);
  const Vec3 ground_forward = Vec3::Unit(plane.up_in_image);
  const Vec3 eye_direction = std::cos(elevation) * (-std::cos(azimuth) * ground_forward -
                                                    std::sin(azimuth) * ground_right) +
                             std::sin(elevation) * up;
  const Vec3 eye = centre + 2.5 * radius * eye_direction;

  // Look-at view matrix (camera x right, y up, looking down -z, as in GL).
  const Vec3 forward = (centre - eye).normalized();
  const Vec3 right = forward.cross(up).normalized();
  const Vec3 camera_up = right.cross(forward);
  Mat4 view = Mat4::Identity();
  view.block<1, 3>(0, 0) = right.transpose();
  view.block<1, 3>(1, 0) = camera_up.transpose();
  view.block<1, 3>(2, 0) = -forward.transpose();
  view(0, 3) = -right.dot(eye);
  view(1, 3) = -camera_up.dot(eye);
  view(2, 3) = forward.dot(eye);

  // Tangent-space extent of the scene (x/depth, y/depth) decides the off-axis frustum.
  double tan_left = 1e9, tan_right = -1e9, tan_bottom = 1e9, tan_top = -1e9;
  double depth_min = 1e9, depth_max = 0.0;
  std::vector<Vec3> corners = points;
  if (corners.empty()) corners.push_back(centre);
  for (const Vec3& p : corners) {
    const Vec4 c = view * p.homogeneous();
    const double depth = -c.z();
    tan_left = std::min(tan_left, c.x() / depth);
    tan_right = std::max(tan_right, c.x() / depth);
    tan_bottom = std::min(tan_bottom, c.y() / depth);
    tan_top = std::max(tan_top, c.y() / depth);
    depth_min = std::min(depth_min, depth);
    depth_max = std::max(depth_max, depth);
  }
  const double padding = 1.04;
  const double tan_span_x = std::max(tan_right - tan_left, 1e-3) * padding;
  const double tan_span_y = std::max(tan_top - tan_bottom, 1e-3) * padding;
  const double tan_centre_x = 0.5 * (tan_left + tan_right);
  const double tan_centre_y = 0.5 * (tan_bottom + tan_top);

  const double W = image_size.width, H = image_size.height;
  const double plot_w = W - margins.left - margins.right;
  const double plot_h = H - margins.top - margins.bottom;
  const double pixels_per_tan = std::min(plot_w / tan_span_x, plot_h / tan_span_y);
  const double centre_u = margins.left + plot_w / 2.0;
  const double centre_v = margins.top + plot_h / 2.0;
  const double l = tan_centre_x - centre_u / pixels_per_tan;
  const double r = tan_centre_x + (W - centre_u) / pixels_per_tan;
  const double t = tan_centre_y + centre_v / pixels_per_tan;
  const double b = tan_centre_y - (H - centre_v) / pixels_per_tan;
  const double near_plane = 0.5 * depth_min;
  const double far_plane = 2.0 * depth_max;

  // glFrustum with the near-plane window (l, r, b, t) * near_plane.
  Mat4 frustum = Mat4::Zero();
  frustum(0, 0) = 2.0 / (r - l);
  frustum(0, 2) = (r + l) / (r - l);
  frustum(1, 1) = 2.0 / (t - b);
  frustum(1, 2) = (t + b) / (t - b);
  frustum(2, 2) = -(far_plane + near_plane) / (far_plane - near_plane);
  frustum(2, 3) = -2.0 * far_plane * near_plane / (far_plane - near_plane);
  frustum(3, 2) = -1.0;
  projection.world_to_clip = frustum * view;
  return projection;
}

double niceTickStep(double range, int target_ticks) {
  if (!(range > 0.0) || target_ticks < 1) return 1.0;
  const double raw = range / target_ticks;
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  const double mantissa = raw / power;
  const double nice = mantissa < 1.5 ? 1.0 : mantissa < 3.5 ? 2.0 : mantissa < 7.5 ? 5.0 : 10.0;
  return nice * power;
}

double niceLengthAtMost(double max_length) {
  if (!(max_length > 0.0)) return 0.0;
  const double power = std::pow(10.0, std::floor(std::log10(max_length) + 1e-12));
  const double mantissa = max_length / power;
  const double nice = mantissa >= 5.0 - 1e-9 ? 5.0 : mantissa >= 2.0 - 1e-9 ? 2.0 : 1.0;
  return nice * power;
}

std::vector<double> ticksIn(double low, double high, double step) {
  std::vector<double> ticks;
  if (!(step > 0.0) || high < low) return ticks;
  const long first = static_cast<long>(std::ceil(low / step - 1e-9));
  const long last = static_cast<long>(std::floor(high / step + 1e-9));
  for (long k = first; k <= last && ticks.size() < 1000; ++k) ticks.push_back(k == 0 ? 0.0 : k * step);
  return ticks;
}

std::string formatTick(double value_m, double step_m) {
  const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step_m) + 1e-9)));
  if (std::abs(value_m) < 1e-6 * step_m) value_m = 0.0;  // no "-0.0"
  char text[32];
  std::snprintf(text, sizeof text, "%.*f", decimals, value_m);
  return text;
}

std::string formatLength(double metres) {
  struct Unit { double size; const char* name; };
  const Unit unit = metres >= 1000.0 ? Unit{1000.0, "km"}
                    : metres >= 1.0  ? Unit{1.0, "m"}
                    : metres >= 0.01 ? Unit{0.01, "cm"}
                                     : Unit{0.001, "mm"};
  char text[32];
  std::snprintf(text, sizeof text, "%g %s", metres / unit.size, unit.name);
  return text;
}

}  // namespace vslam
