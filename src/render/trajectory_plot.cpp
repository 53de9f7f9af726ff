#include "vslam/render/trajectory_plot.hpp"

#include <algorithm>
#include <filesystem>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "vslam/render/plot_canvas.hpp"

namespace vslam {
namespace {

bool hasErrors(const TrajectoryPlotInput& input) {
  return !input.error_m.empty() && input.error_m.size() == input.estimate.size();
}

double maxError(const TrajectoryPlotInput& input) {
  // The colour scale spans at least 1 mm, so a near-perfect estimate reads as
  // uniformly "no error" instead of amplified noise.
  double max_error = 1e-3;
  if (hasErrors(input))
    for (double e : input.error_m) max_error = std::max(max_error, e);
  return max_error;
}

std::vector<cv::Scalar> estimateColours(const TrajectoryPlotInput& input) {
  if (!hasErrors(input)) return std::vector<cv::Scalar>(input.estimate.size(), kEstimateColour);
  const double max_error = maxError(input);
  std::vector<cv::Scalar> colours;
  for (double e : input.error_m) colours.push_back(viridisColour(max_error > 0 ? e / max_error : 0.0));
  return colours;
}

// Widths in final pixels: the estimate on top and wider, so where the two
// paths agree the ground truth disappears under it.
constexpr double kGroundTruthWidth = 2.0;
constexpr double kEstimateWidth = 3.5;

void drawPaths(PlotCanvas& canvas, const TrajectoryPlotInput& input) {
  canvas.drawPolyline(input.groundtruth, plot_colour::kGroundTruth, kGroundTruthWidth, /*dashed=*/true);
  canvas.drawColouredPolyline(input.estimate, estimateColours(input), kEstimateWidth);
}

std::vector<LegendEntry> legendFor(const TrajectoryPlotInput& input) {
  std::vector<LegendEntry> legend;
  if (!input.groundtruth.empty())
    legend.push_back({"ground truth", LegendEntry::Sample::DashedLine, plot_colour::kGroundTruth});
  if (!input.estimate.empty()) {
    if (hasErrors(input))
      legend.push_back({"estimate (colour = error)", LegendEntry::Sample::Gradient, {}});
    else
      legend.push_back({"estimate", LegendEntry::Sample::Line, kEstimateColour});
  }
  return legend;
}

void drawStartMarker(cv::Mat& image, const PlotProjection& projection, const std::vector<Vec3>& path) {
  if (path.empty() || !projection.inFront(path.front())) return;
  const cv::Point2d start = projection.toPixel(path.front());
  const cv::Point centre(static_cast<int>(std::lround(start.x)), static_cast<int>(std::lround(start.y)));
  cv::circle(image, centre, 7, plot_colour::kInk, 2, cv::LINE_AA);
  drawText(image, "start", centre + cv::Point(11, -9), 0.5, plot_colour::kInk);
}

// Colour bar and (top view) scale bar share the right margin.
void drawRightMargin(cv::Mat& image, const TrajectoryPlotInput& input, const PlotMargins& margins,
                     double pixels_per_m) {
  const cv::Rect area = plotArea(image.size(), margins);
  const int x = area.x + area.width + 40;
  int y = area.y + 30;
  if (hasErrors(input)) y = drawErrorColourBar(image, {x, y}, area.height / 2, maxError(input)) + 60;
  if (pixels_per_m > 0) {
    drawText(image, "scale", {x, y - 30}, 0.55, plot_colour::kInk);
    drawScaleBar(image, {x, y}, margins.right - 60, pixels_per_m);
  }
}

std::vector<Vec3> allPositions(const TrajectoryPlotInput& input) {
  std::vector<Vec3> all = input.groundtruth;
  all.insert(all.end(), input.estimate.begin(), input.estimate.end());
  return all;
}

cv::Mat renderTop(const TrajectoryPlotInput& input, cv::Size size, PlotProjection& projection) {
  const PlotMargins margins;
  projection = fitTopView(allPositions(input), size, margins);
  const cv::Rect area = plotArea(size, margins);
  double low_right, high_right, low_up, high_up;
  topViewWorldRange(projection, area, low_right, high_right, low_up, high_up);
  const double tick_step = niceTickStep(std::max(high_right - low_right, high_up - low_up), 8);

  PlotCanvas canvas(projection);
  canvas.clipTo(area);
  canvas.drawGroundGrid(projection.plane, projection.plane_level, low_right, high_right, low_up, high_up, tick_step,
                        plot_colour::kGrid, 1.0);
  drawPaths(canvas, input);
  cv::Mat image = canvas.finish();

  drawStartMarker(image, projection, input.estimate.empty() ? input.groundtruth : input.estimate);
  drawTopViewAxes(image, projection, area, tick_step);
  drawTitle(image, input.title);
  drawLegendRow(image, legendFor(input), 72);
  const double pixels_per_m = projection.toPixel(Vec3::Unit(projection.plane.right)).x - projection.toPixel(Vec3::Zero()).x;
  drawRightMargin(image, input, margins, pixels_per_m);
  return image;
}

cv::Mat renderPerspective(const TrajectoryPlotInput& input, cv::Size size, PlotProjection& projection) {
  const PlotMargins margins;
  const std::vector<Vec3> positions = allPositions(input);
  const GroundGrid grid = groundGridFor(positions);
  std::vector<Vec3> fitted = positions;
  for (const Vec3& corner : grid.corners()) fitted.push_back(corner);
  projection = fitPerspectiveView(fitted, size, margins);

  // The estimate's shadow on the grid shows height at a glance.
  std::vector<Vec3> shadow;
  for (const Vec3& p : input.estimate) shadow.push_back(p + (grid.level - grid.plane.toward_viewer.dot(p)) * grid.plane.toward_viewer);

  PlotCanvas canvas(projection);
  drawGroundGrid(canvas, grid);
  canvas.drawPolyline(shadow, cv::Scalar(185, 185, 185), 2.0);
  drawPaths(canvas, input);
  cv::Mat image = canvas.finish();

  drawStartMarker(image, projection, input.estimate.empty() ? input.groundtruth : input.estimate);
  drawGroundGridLabels(image, projection, grid);
  drawTitle(image, input.title);
  std::vector<LegendEntry> legend = legendFor(input);
  if (!shadow.empty()) legend.push_back({"shadow on ground", LegendEntry::Sample::Line, cv::Scalar(185, 185, 185)});
  legend.push_back({"grid " + formatLength(grid.step), LegendEntry::Sample::Line, cv::Scalar(205, 205, 205)});
  drawLegendRow(image, legend, 72);
  drawRightMargin(image, input, margins, /*pixels_per_m=*/0.0);  // no single scale in perspective
  return image;
}

}  // namespace

cv::Mat renderTrajectoryPlot(const TrajectoryPlotInput& input, PlotView view, cv::Size size,
                             PlotProjection* used_projection) {
  PlotProjection projection;
  cv::Mat image = view == PlotView::Top ? renderTop(input, size, projection) : renderPerspective(input, size, projection);
  if (used_projection) *used_projection = projection;
  return image;
}

void writeTrajectoryPlots(const TrajectoryPlotInput& input, const std::string& out_dir) {
  std::filesystem::create_directories(out_dir);
  for (const auto& [view, name] : {std::pair{PlotView::Top, "trajectory_top.png"}, std::pair{PlotView::Perspective, "trajectory_3d.png"}}) {
    const std::string path = (std::filesystem::path(out_dir) / name).string();
    if (!cv::imwrite(path, renderTrajectoryPlot(input, view)))
      throw std::runtime_error(path + ": cannot write the PNG");
  }
}

}  // namespace vslam
