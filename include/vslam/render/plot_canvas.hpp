#pragma once
// Building blocks shared by the trajectory and map renders: a supersampled GL
// canvas for the geometry and an OpenCV pass for text, legends and bars.
//
// OSMesa has no multisampling, so the canvas renders at kSupersampling times
// the final size and shrinks with INTER_AREA: lines come out smooth. All sizes
// given to the canvas are in final-image pixels.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/core/types.hpp"
#include "vslam/render/osmesa_context.hpp"
#include "vslam/render/plot_projection.hpp"

namespace vslam {

constexpr int kSupersampling = 2;

// Page and ink colours (BGR) every render uses.
namespace plot_colour {
const cv::Scalar kBackground(255, 255, 255);
const cv::Scalar kInk(40, 40, 40);           // text, axes frame
const cv::Scalar kGrid(225, 225, 225);       // grid lines
const cv::Scalar kGroundTruth(90, 90, 90);   // dashed ground-truth path
}  // namespace plot_colour

class PlotCanvas {
 public:
  // White page, depth test off, the projection loaded.
  explicit PlotCanvas(const PlotProjection& projection);

  const PlotProjection& projection() const { return projection_; }

  void setDepthTest(bool enabled);
  // Restricts drawing to a final-image rectangle (e.g. the plot area).
  void clipTo(const cv::Rect& final_pixels);
  void noClip();

  void drawPolyline(const std::vector<Vec3>& points, const cv::Scalar& bgr, double width_px, bool dashed = false);
  // One colour per vertex; segment i takes the colour of vertex i + 1. Round
  // dots at the vertices close the gaps GL leaves between wide segments.
  void drawColouredPolyline(const std::vector<Vec3>& points, const std::vector<cv::Scalar>& bgr, double width_px);
  // Pairs of endpoints.
  void drawSegments(const std::vector<Vec3>& endpoints, const cv::Scalar& bgr, double width_px);
  // Square points by default (solid at small sizes); round ones are antialiased.
  void drawPoints(const std::vector<Vec3>& points, const std::vector<cv::Scalar>& bgr, double size_px,
                  bool round = false);
  // A grid of lines on the plane `plane_axis_value` along plane.toward_viewer,
  // lines every `step` over [low_right, high_right] x [low_up, high_up].
  void drawGroundGrid(const TopPlane& plane, double plane_axis_value, double low_right, double high_right,
                      double low_up, double high_up, double step, const cv::Scalar& bgr, double width_px);

  // Reads back and shrinks to the final size.
  cv::Mat finish();

 private:
  PlotProjection projection_;
  OsmesaContext context_;
};

// ---- colour --------------------------------------------------------------

// Viridis (dark violet -> blue -> green -> yellow), t clamped to [0, 1]. Ends
// at a darker yellow than the original so the top of the scale stays visible on white.
cv::Scalar viridisColour(double t);

// ---- text pass (OpenCV, on the final image) -------------------------------

// Hershey fonts know ASCII only: maps the usual typographic characters of our
// titles (em/en dash, degree, micro, times) to ASCII and anything else to '?'.
std::string toHersheyText(const std::string& utf8);

enum class TextAnchor { Left, Centre, Right };
// `origin` is the left end of the baseline for Left; Centre and Right shift the text left.
void drawText(cv::Mat& image, const std::string& text, cv::Point origin, double scale,
              const cv::Scalar& bgr, TextAnchor anchor = TextAnchor::Left, int thickness = 1);
// Text on a filled box (for labels drawn over geometry).
void drawLabel(cv::Mat& image, const std::string& text, cv::Point bottom_left, const cv::Scalar& box_bgr,
               double scale = 0.5);

void drawTitle(cv::Mat& image, const std::string& title);

struct LegendEntry {
  enum class Sample { Line, DashedLine, Gradient, Swatch, Frustum };
  std::string label;
  Sample sample = Sample::Line;
  cv::Scalar bgr = plot_colour::kInk;
};
// One row under the title, left to right.
void drawLegendRow(cv::Mat& image, const std::vector<LegendEntry>& entries, int baseline_y);
// A column of entries starting at top_left (for lists of classes).
void drawLegendColumn(cv::Mat& image, const std::vector<LegendEntry>& entries, cv::Point top_left);

// Vertical viridis bar for [0, max_error_m], labelled in cm (in m from 2 m up).
// Returns the y just below it.
int drawErrorColourBar(cv::Mat& image, cv::Point top_left, int height, double max_error_m);

// A bar of a nice length (niceLengthAtMost) no longer than max_width_px,
// labelled with its length; pixels_per_m from the projection.
void drawScaleBar(cv::Mat& image, cv::Point left_end, int max_width_px, double pixels_per_m);

// Frame around the plot area with metre ticks and labels on the bottom and
// left edges (top view, ticks every tick_step_m) and names for the two axes.
void drawTopViewAxes(cv::Mat& image, const PlotProjection& projection, const cv::Rect& plot_area, double tick_step_m);

// Plot area of a render of `size` with `margins`.
cv::Rect plotArea(cv::Size size, const PlotMargins& margins);

// World-space range (along plane.right and plane.up_in_image) that a top view shows in `area`.
void topViewWorldRange(const PlotProjection& projection, const cv::Rect& area, double& low_right,
                       double& high_right, double& low_up, double& high_up);

const char* axisName(int axis);  // "x", "y", "z"

// The ground grid of a perspective view: on the plane chooseTopPlane picks,
// at the lowest point of the scene along plane.toward_viewer, covering the
// scene snapped outward to whole steps.
struct GroundGrid {
  TopPlane plane;
  double level = 0.0;  // coordinate along plane.toward_viewer
  double low_right = 0, high_right = 0, low_up = 0, high_up = 0;
  double step = 1.0;
  std::vector<Vec3> corners() const;         // with room for the labels, for fitting the view
  Vec3 point(double right, double up) const;  // on the grid plane
};
GroundGrid groundGridFor(const std::vector<Vec3>& points);
void drawGroundGrid(PlotCanvas& canvas, const GroundGrid& grid);
// Metre labels along the two grid edges nearest the camera and the axis names.
void drawGroundGridLabels(cv::Mat& image, const PlotProjection& projection, const GroundGrid& grid);

}  // namespace vslam
