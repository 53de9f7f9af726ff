#include "vslam/render/plot_canvas.hpp"

#include <algorithm>
#include <cmath>

#include <GL/gl.h>
#include <opencv2/imgproc.hpp>

namespace vslam {
namespace {

void setColour(const cv::Scalar& bgr) {
  glColor3ub(static_cast<GLubyte>(bgr[2]), static_cast<GLubyte>(bgr[1]), static_cast<GLubyte>(bgr[0]));
}

void vertex(const Vec3& p) { glVertex3d(p.x(), p.y(), p.z()); }

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

}  // namespace

PlotCanvas::PlotCanvas(const PlotProjection& projection)
    : projection_(projection),
      context_(projection.image_size.width * kSupersampling, projection.image_size.height * kSupersampling) {
  glViewport(0, 0, context_.width(), context_.height());
  const cv::Scalar& page = plot_colour::kBackground;
  glClearColor(page[2] / 255.0f, page[1] / 255.0f, page[0] / 255.0f, 1.0f);
  glClearDepth(1.0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glMatrixMode(GL_PROJECTION);
  glLoadMatrixd(projection_.world_to_clip.data());  // Eigen is column-major, as GL expects
  glMatrixMode(GL_MODELVIEW);
  glLoadIdentity();
  glDepthFunc(GL_LEQUAL);
  glDisable(GL_DEPTH_TEST);
  // Round (smooth) points need blending of their antialiased rim.
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
}

void PlotCanvas::setDepthTest(bool enabled) {
  if (enabled)
    glEnable(GL_DEPTH_TEST);
  else
    glDisable(GL_DEPTH_TEST);
}

void PlotCanvas::clipTo(const cv::Rect& final_pixels) {
  glEnable(GL_SCISSOR_TEST);
  const int bottom_up_y = projection_.image_size.height - (final_pixels.y + final_pixels.height);
  glScissor(final_pixels.x * kSupersampling, bottom_up_y * kSupersampling, final_pixels.width * kSupersampling,
            final_pixels.height * kSupersampling);
}

void PlotCanvas::noClip() { glDisable(GL_SCISSOR_TEST); }

void PlotCanvas::drawPolyline(const std::vector<Vec3>& points, const cv::Scalar& bgr, double width_px,
                              bool dashed) {
  if (points.size() < 2) return;
  glLineWidth(static_cast<float>(width_px * kSupersampling));
  if (dashed) {
    glEnable(GL_LINE_STIPPLE);
    glLineStipple(kSupersampling * 2, 0x3F3F);  // 6 px on, 2 px off, twice per pattern
  }
  setColour(bgr);
  glBegin(GL_LINE_STRIP);
  for (const Vec3& p : points) vertex(p);
  glEnd();
  glDisable(GL_LINE_STIPPLE);
}

void PlotCanvas::drawColouredPolyline(const std::vector<Vec3>& points, const std::vector<cv::Scalar>& bgr,
                                      double width_px) {
  if (points.empty() || bgr.size() != points.size()) return;
  glLineWidth(static_cast<float>(width_px * kSupersampling));
  glBegin(GL_LINES);
  for (size_t i = 1; i < points.size(); ++i) {
    setColour(bgr[i]);
    vertex(points[i - 1]);
    vertex(points[i]);
  }
  glEnd();
  drawPoints(points, bgr, width_px, /*round=*/true);
}

void PlotCanvas::drawSegments(const std::vector<Vec3>& endpoints, const cv::Scalar& bgr, double width_px) {
  glLineWidth(static_cast<float>(width_px * kSupersampling));
  setColour(bgr);
  glBegin(GL_LINES);
  for (size_t i = 0; i + 1 < endpoints.size(); i += 2) {
    vertex(endpoints[i]);
    vertex(endpoints[i + 1]);
  }
  glEnd();
}

void PlotCanvas::drawPoints(const std::vector<Vec3>& points, const std::vector<cv::Scalar>& bgr, double size_px,
                            bool round) {
  if (bgr.size() != points.size()) return;
  if (round)
    glEnable(GL_POINT_SMOOTH);
  else
    glDisable(GL_POINT_SMOOTH);
  glPointSize(static_cast<float>(size_px * kSupersampling));
  glBegin(GL_POINTS);
  for (size_t i = 0; i < points.size(); ++i) {
    setColour(bgr[i]);
    vertex(points[i]);
  }
  glEnd();
}

void PlotCanvas::drawGroundGrid(const TopPlane& plane, double plane_axis_value, double low_right,
                                double high_right, double low_up, double high_up, double step,
                                const cv::Scalar& bgr, double width_px) {
  const Vec3 right = Vec3::Unit(plane.right);
  const Vec3 up = Vec3::Unit(plane.up_in_image);
  const Vec3 offset = plane.toward_viewer * plane_axis_value;
  std::vector<Vec3> endpoints;
  for (double a : ticksIn(low_right, high_right, step)) {
    endpoints.push_back(offset + a * right + low_up * up);
    endpoints.push_back(offset + a * right + high_up * up);
  }
  for (double b : ticksIn(low_up, high_up, step)) {
    endpoints.push_back(offset + low_right * right + b * up);
    endpoints.push_back(offset + high_right * right + b * up);
  }
  drawSegments(endpoints, bgr, width_px);
}

cv::Mat PlotCanvas::finish() {
  const cv::Mat supersampled = context_.readPixels();
  cv::Mat image;
  cv::resize(supersampled, image, projection_.image_size, 0, 0, cv::INTER_AREA);
  return image;
}

// ---- colour ----------------------------------------------------------------

cv::Scalar viridisColour(double t) {
  // Viridis-like stops (RGB) at ninths of the range; the last is darker than
  // viridis' (253, 231, 37) so it stays visible on white.
  static constexpr unsigned char kStops[][3] = {{68, 1, 84},    {72, 36, 117},  {65, 68, 135},
                                                {53, 95, 141},  {42, 120, 142}, {33, 145, 140},
                                                {34, 168, 132}, {68, 191, 112}, {122, 209, 81},
                                                {220, 205, 30}};
  constexpr int kLast = static_cast<int>(sizeof kStops / sizeof kStops[0]) - 1;
  const double x = std::clamp(std::isfinite(t) ? t : 0.0, 0.0, 1.0) * kLast;
  const int i = std::min(static_cast<int>(x), kLast - 1);
  const double f = x - i;
  auto mix = [&](int c) { return std::round((1.0 - f) * kStops[i][c] + f * kStops[i + 1][c]); };
  return cv::Scalar(mix(2), mix(1), mix(0));
}

// ---- text pass -------------------------------------------------------------

std::string toHersheyText(const std::string& utf8) {
  struct Replacement { const char* from; const char* to; };
  static constexpr Replacement kReplacements[] = {
      {"\xE2\x80\x94", "-"}, {"\xE2\x80\x93", "-"}, {"\xC2\xB0", " deg"}, {"\xC2\xB5", "u"},
      {"\xC3\x97", "x"},     {"\xE2\x80\xA6", "..."}};
  std::string out;
  for (size_t i = 0; i < utf8.size();) {
    const unsigned char c = static_cast<unsigned char>(utf8[i]);
    if (c < 0x80) {
      out += utf8[i++];
      continue;
    }
    bool replaced = false;
    for (const auto& r : kReplacements) {
      const std::string from = r.from;
      if (utf8.compare(i, from.size(), from) == 0) {
        out += r.to;
        i += from.size();
        replaced = true;
        break;
      }
    }
    if (replaced) continue;
    out += '?';
    ++i;
    while (i < utf8.size() && (static_cast<unsigned char>(utf8[i]) & 0xC0) == 0x80) ++i;  // rest of the character
  }
  return out;
}

void drawText(cv::Mat& image, const std::string& text, cv::Point origin, double scale, const cv::Scalar& bgr,
              TextAnchor anchor, int thickness) {
  const std::string ascii = toHersheyText(text);
  int baseline = 0;
  const cv::Size size = cv::getTextSize(ascii, kFont, scale, thickness, &baseline);
  if (anchor == TextAnchor::Centre) origin.x -= size.width / 2;
  if (anchor == TextAnchor::Right) origin.x -= size.width;
  cv::putText(image, ascii, origin, kFont, scale, bgr, thickness, cv::LINE_AA);
}

void drawLabel(cv::Mat& image, const std::string& text, cv::Point bottom_left, const cv::Scalar& box_bgr,
               double scale) {
  const std::string ascii = toHersheyText(text);
  int baseline = 0;
  const cv::Size size = cv::getTextSize(ascii, kFont, scale, 1, &baseline);
  const int pad = 4;
  cv::Rect box(bottom_left.x, bottom_left.y - size.height - 2 * pad, size.width + 2 * pad, size.height + 2 * pad);
  // Keep labels of things near the border on the page.
  box.x = std::clamp(box.x, 0, std::max(0, image.cols - box.width));
  box.y = std::clamp(box.y, 0, std::max(0, image.rows - box.height));
  cv::rectangle(image, box, box_bgr, cv::FILLED);
  const double luminance = 0.114 * box_bgr[0] + 0.587 * box_bgr[1] + 0.299 * box_bgr[2];
  const cv::Scalar text_bgr = luminance > 150 ? cv::Scalar(0, 0, 0) : cv::Scalar(255, 255, 255);
  cv::putText(image, ascii, {box.x + pad, box.y + pad + size.height}, kFont, scale, text_bgr, 1, cv::LINE_AA);
}

void drawTitle(cv::Mat& image, const std::string& title) {
  const std::string ascii = toHersheyText(title);
  double scale = 0.85;
  int baseline = 0;
  while (scale > 0.4 && cv::getTextSize(ascii, kFont, scale, 2, &baseline).width > image.cols - 40) scale -= 0.05;
  drawText(image, ascii, {image.cols / 2, 38}, scale, plot_colour::kInk, TextAnchor::Centre, 2);
}

namespace {

constexpr int kSampleWidth = 36;

void drawLegendSample(cv::Mat& image, const LegendEntry& entry, cv::Point left_mid) {
  const cv::Point right_mid = left_mid + cv::Point(kSampleWidth, 0);
  switch (entry.sample) {
    case LegendEntry::Sample::Line:
      cv::line(image, left_mid, right_mid, entry.bgr, 3, cv::LINE_AA);
      break;
    case LegendEntry::Sample::DashedLine:
      for (int x = 0; x < kSampleWidth; x += 10)
        cv::line(image, left_mid + cv::Point(x, 0), left_mid + cv::Point(std::min(x + 6, kSampleWidth), 0),
                 entry.bgr, 2, cv::LINE_AA);
      break;
    case LegendEntry::Sample::Gradient:
      for (int x = 0; x < kSampleWidth; ++x)
        cv::line(image, left_mid + cv::Point(x, -2), left_mid + cv::Point(x, 2),
                 viridisColour(static_cast<double>(x) / (kSampleWidth - 1)), 1);
      break;
    case LegendEntry::Sample::Swatch:
      cv::rectangle(image, cv::Rect(left_mid.x + kSampleWidth / 2 - 7, left_mid.y - 7, 14, 14), entry.bgr,
                    cv::FILLED);
      break;
    case LegendEntry::Sample::Frustum: {
      const cv::Point apex = left_mid + cv::Point(8, 0);
      const cv::Point top = left_mid + cv::Point(28, -8), bottom = left_mid + cv::Point(28, 8);
      cv::line(image, apex, top, entry.bgr, 2, cv::LINE_AA);
      cv::line(image, apex, bottom, entry.bgr, 2, cv::LINE_AA);
      cv::line(image, top, bottom, entry.bgr, 2, cv::LINE_AA);
      break;
    }
  }
}

}  // namespace

void drawLegendRow(cv::Mat& image, const std::vector<LegendEntry>& entries, int baseline_y) {
  const double scale = 0.55;
  int total = 0;
  std::vector<int> widths;
  for (const LegendEntry& entry : entries) {
    int baseline = 0;
    widths.push_back(kSampleWidth + 8 + cv::getTextSize(toHersheyText(entry.label), kFont, scale, 1, &baseline).width);
    total += widths.back() + 30;
  }
  int x = std::max(10, (image.cols - total + 30) / 2);
  for (size_t i = 0; i < entries.size(); ++i) {
    drawLegendSample(image, entries[i], {x, baseline_y - 5});
    drawText(image, entries[i].label, {x + kSampleWidth + 8, baseline_y}, scale, plot_colour::kInk);
    x += widths[i] + 30;
  }
}

void drawLegendColumn(cv::Mat& image, const std::vector<LegendEntry>& entries, cv::Point top_left) {
  int y = top_left.y + 14;
  for (const LegendEntry& entry : entries) {
    drawLegendSample(image, entry, {top_left.x, y - 5});
    drawText(image, entry.label, {top_left.x + kSampleWidth + 6, y}, 0.5, plot_colour::kInk);
    y += 24;
  }
}

int drawErrorColourBar(cv::Mat& image, cv::Point top_left, int height, double max_error_m) {
  const bool in_metres = max_error_m >= 2.0;
  const double unit = in_metres ? 1.0 : 0.01;
  const double max_value = max_error_m > 0.0 ? max_error_m / unit : 1.0;
  const int width = 22;
  drawText(image, in_metres ? "error [m]" : "error [cm]", top_left + cv::Point(0, -12), 0.55, plot_colour::kInk);
  for (int row = 0; row < height; ++row) {
    const double t = 1.0 - static_cast<double>(row) / (height - 1);
    cv::line(image, top_left + cv::Point(0, row), top_left + cv::Point(width - 1, row), viridisColour(t), 1);
  }
  cv::rectangle(image, cv::Rect(top_left.x, top_left.y, width, height), plot_colour::kInk, 1);
  const double step = niceTickStep(max_value, 5);
  for (double value : ticksIn(0.0, max_value, step)) {
    const int y = top_left.y + static_cast<int>(std::lround((1.0 - value / max_value) * (height - 1)));
    cv::line(image, {top_left.x + width, y}, {top_left.x + width + 5, y}, plot_colour::kInk, 1);
    drawText(image, formatTick(value, step), {top_left.x + width + 9, y + 5}, 0.5, plot_colour::kInk);
  }
  return top_left.y + height;
}

void drawScaleBar(cv::Mat& image, cv::Point left_end, int max_width_px, double pixels_per_m) {
  if (!(pixels_per_m > 0.0)) return;
  const double length_m = niceLengthAtMost(max_width_px / pixels_per_m);
  const int length_px = static_cast<int>(std::lround(length_m * pixels_per_m));
  const cv::Point right_end = left_end + cv::Point(length_px, 0);
  cv::line(image, left_end, right_end, plot_colour::kInk, 3);
  cv::line(image, left_end + cv::Point(0, -7), left_end + cv::Point(0, 7), plot_colour::kInk, 2);
  cv::line(image, right_end + cv::Point(0, -7), right_end + cv::Point(0, 7), plot_colour::kInk, 2);
  drawText(image, formatLength(length_m), {left_end.x + length_px / 2, left_end.y - 12}, 0.55, plot_colour::kInk,
           TextAnchor::Centre);
}

cv::Rect plotArea(cv::Size size, const PlotMargins& margins) {
  return {margins.left, margins.top, size.width - margins.left - margins.right,
          size.height - margins.top - margins.bottom};
}

void topViewWorldRange(const PlotProjection& projection, const cv::Rect& area, double& low_right,
                       double& high_right, double& low_up, double& high_up) {
  const TopPlane& plane = projection.plane;
  const cv::Point2d origin = projection.toPixel(Vec3::Zero());
  const double pixels_per_m = projection.toPixel(Vec3::Unit(plane.right)).x - origin.x;
  low_right = (area.x - 0.5 - origin.x) / pixels_per_m;
  high_right = (area.x + area.width - 0.5 - origin.x) / pixels_per_m;
  high_up = (origin.y - (area.y - 0.5)) / pixels_per_m;
  low_up = (origin.y - (area.y + area.height - 0.5)) / pixels_per_m;
}

const char* axisName(int axis) { return axis == 0 ? "x" : axis == 1 ? "y" : "z"; }

void drawTopViewAxes(cv::Mat& image, const PlotProjection& projection, const cv::Rect& plot_area,
                     double tick_step_m) {
  const TopPlane& plane = projection.plane;
  double low_right, high_right, low_up, high_up;
  topViewWorldRange(projection, plot_area, low_right, high_right, low_up, high_up);
  const int left = plot_area.x, right = plot_area.x + plot_area.width;
  const int top = plot_area.y, bottom = plot_area.y + plot_area.height;
  cv::rectangle(image, plot_area, plot_colour::kInk, 1);
  for (double value : ticksIn(low_right, high_right, tick_step_m)) {
    const int u = static_cast<int>(std::lround(projection.toPixel(value * Vec3::Unit(plane.right)).x));
    cv::line(image, {u, bottom}, {u, bottom + 6}, plot_colour::kInk, 1);
    drawText(image, formatTick(value, tick_step_m), {u, bottom + 24}, 0.5, plot_colour::kInk, TextAnchor::Centre);
  }
  for (double value : ticksIn(low_up, high_up, tick_step_m)) {
    const int v = static_cast<int>(std::lround(projection.toPixel(value * Vec3::Unit(plane.up_in_image)).y));
    cv::line(image, {left - 6, v}, {left, v}, plot_colour::kInk, 1);
    drawText(image, formatTick(value, tick_step_m), {left - 10, v + 5}, 0.5, plot_colour::kInk, TextAnchor::Right);
  }
  drawText(image, std::string(axisName(plane.right)) + " [m]", {(left + right) / 2, bottom + 52}, 0.6,
           plot_colour::kInk, TextAnchor::Centre);
  drawText(image, std::string(axisName(plane.up_in_image)) + " [m]", {left - 10, top - 10}, 0.6, plot_colour::kInk,
           TextAnchor::Right);
}

}  // namespace vslam

namespace vslam {

Vec3 GroundGrid::point(double right, double up) const {
  return right * Vec3::Unit(plane.right) + up * Vec3::Unit(plane.up_in_image) + level * plane.toward_viewer;
}

std::vector<Vec3> GroundGrid::corners() const {
  // Includes the strip outside the near edges where drawGroundGridLabels writes.
  const double label_room = 0.6 * step;
  return {point(low_right, low_up),
          point(high_right, low_up),
          point(low_right, high_up),
          point(high_right, high_up),
          point(low_right, low_up - label_room),
          point(high_right, low_up - label_room),
          point(low_right - label_room, low_up),
          point(low_right - label_room, high_up)};
}

GroundGrid groundGridFor(const std::vector<Vec3>& points) {
  GroundGrid grid;
  grid.plane = chooseTopPlane(points);
  if (points.empty()) return grid;
  double min_right = 1e300, max_right = -1e300, min_up = 1e300, max_up = -1e300;
  grid.level = 1e300;
  for (const Vec3& p : points) {
    min_right = std::min(min_right, p[grid.plane.right]);
    max_right = std::max(max_right, p[grid.plane.right]);
    min_up = std::min(min_up, p[grid.plane.up_in_image]);
    max_up = std::max(max_up, p[grid.plane.up_in_image]);
    grid.level = std::min(grid.level, grid.plane.toward_viewer.dot(p));
  }
  grid.step = niceTickStep(std::max({max_right - min_right, max_up - min_up, 0.05}), 6);
  // Snap outward, and keep at least half a step of border round the scene.
  grid.low_right = std::floor((min_right - 0.5 * grid.step) / grid.step) * grid.step;
  grid.high_right = std::ceil((max_right + 0.5 * grid.step) / grid.step) * grid.step;
  grid.low_up = std::floor((min_up - 0.5 * grid.step) / grid.step) * grid.step;
  grid.high_up = std::ceil((max_up + 0.5 * grid.step) / grid.step) * grid.step;
  return grid;
}

void drawGroundGrid(PlotCanvas& canvas, const GroundGrid& grid) {
  canvas.drawGroundGrid(grid.plane, grid.level, grid.low_right, grid.high_right, grid.low_up, grid.high_up,
                        grid.step, cv::Scalar(205, 205, 205), 1.0);
}

void drawGroundGridLabels(cv::Mat& image, const PlotProjection& projection, const GroundGrid& grid) {
  // The camera stands off the low-up, low-right corner (fitPerspectiveView), so
  // those two edges face it; labels sit just outside them.
  const double gap = 0.35 * grid.step;
  auto label = [&](const Vec3& where, const std::string& text, double scale) {
    if (!projection.inFront(where)) return;
    const cv::Point2d px = projection.toPixel(where);
    drawText(image, text, {static_cast<int>(std::lround(px.x)), static_cast<int>(std::lround(px.y)) + 5}, scale,
             plot_colour::kInk, TextAnchor::Centre);
  };
  for (double value : ticksIn(grid.low_right, grid.high_right, grid.step))
    label(grid.point(value, grid.low_up - gap), formatTick(value, grid.step), 0.45);
  for (double value : ticksIn(grid.low_up, grid.high_up, grid.step))
    label(grid.point(grid.low_right - gap, value), formatTick(value, grid.step), 0.45);
  label(grid.point(0.5 * (grid.low_right + grid.high_right), grid.low_up - 2.6 * gap),
        std::string(axisName(grid.plane.right)) + " [m]", 0.6);
  label(grid.point(grid.low_right - 2.6 * gap, 0.5 * (grid.low_up + grid.high_up)),
        std::string(axisName(grid.plane.up_in_image)) + " [m]", 0.6);
}

}  // namespace vslam
