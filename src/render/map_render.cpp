#include "vslam/render/map_render.hpp"

#include <algorithm>
#include <array>
#include <filesystem>
#include <map>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

#include "vslam/render/plot_canvas.hpp"

namespace vslam {
namespace {

// RGB. Picked greedily, each the colour farthest in CIELAB from those before
// it, out of the 6-level RGB cube without greys (chroma < 30) and without the
// very light (L > 82, lost on white) or very dark (L < 30); started at crimson
// for class 0 (person). Every pair is >= 51 apart in RGB.
constexpr unsigned char kClassPalette[80][3] = {
      {204, 0, 51}, {0, 204, 0}, {0, 0, 255}, {51, 204, 255}, {255, 0, 204}, {204, 153, 0}, {0, 102, 51}, {153, 102, 153},
      {0, 102, 255}, {153, 204, 102}, {255, 102, 0}, {255, 153, 153}, {153, 102, 51}, {204, 0, 255}, {51, 153, 255}, {255, 153, 255},
      {0, 204, 153}, {153, 0, 102}, {102, 51, 153}, {0, 153, 153}, {0, 102, 153}, {255, 51, 153}, {204, 102, 255}, {204, 204, 0},
      {0, 153, 51}, {153, 51, 0}, {102, 102, 0}, {102, 0, 204}, {255, 0, 0}, {255, 153, 102}, {255, 153, 204}, {153, 204, 153},
      {153, 0, 153}, {204, 51, 102}, {153, 51, 51}, {102, 153, 0}, {255, 153, 0}, {255, 0, 102}, {255, 102, 102}, {51, 102, 0},
      {204, 102, 0}, {153, 153, 0}, {102, 102, 204}, {255, 102, 204}, {153, 204, 0}, {204, 51, 0}, {0, 51, 204}, {102, 153, 204},
      {204, 0, 153}, {204, 204, 102}, {255, 51, 255}, {0, 204, 102}, {51, 153, 102}, {153, 153, 255}, {204, 153, 102}, {102, 204, 204},
      {255, 0, 51}, {204, 153, 204}, {102, 204, 51}, {102, 102, 153}, {153, 204, 255}, {204, 102, 102}, {204, 102, 153}, {153, 102, 0},
      {204, 102, 204}, {204, 51, 204}, {153, 51, 204}, {51, 51, 255}, {255, 102, 153}, {255, 102, 255}, {204, 102, 51}, {153, 51, 255},
      {204, 153, 255}, {153, 0, 51}, {153, 102, 255}, {153, 102, 204}, {153, 51, 102}, {51, 153, 0}, {153, 0, 0}, {102, 204, 102},
};

constexpr const char* kCocoNames[80] = {
    "person",        "bicycle",      "car",           "motorbike",     "aeroplane",   "bus",
    "train",         "truck",        "boat",          "traffic light", "fire hydrant", "stop sign",
    "parking meter", "bench",        "bird",          "cat",           "dog",         "horse",
    "sheep",         "cow",          "elephant",      "bear",          "zebra",       "giraffe",
    "backpack",      "umbrella",     "handbag",       "tie",           "suitcase",    "frisbee",
    "skis",          "snowboard",    "sports ball",   "kite",          "baseball bat", "baseball glove",
    "skateboard",    "surfboard",    "tennis racket", "bottle",        "wine glass",  "cup",
    "fork",          "knife",        "spoon",         "bowl",          "banana",      "apple",
    "sandwich",      "orange",       "broccoli",      "carrot",        "hot dog",     "pizza",
    "donut",         "cake",         "chair",         "sofa",          "pottedplant", "bed",
    "diningtable",   "toilet",       "tvmonitor",     "laptop",        "mouse",       "remote",
    "keyboard",      "cell phone",   "microwave",     "oven",          "toaster",     "sink",
    "refrigerator",  "book",         "clock",         "vase",          "scissors",    "teddy bear",
    "hair drier",    "toothbrush"};

const cv::Scalar kUnlabelledGrey(200, 200, 200);
const cv::Scalar kKeyframeColour(150, 70, 20);    // BGR dark blue
const cv::Scalar kTrajectoryColour(0, 120, 230);  // BGR orange

// Fit the view to what matters: a few stray points far away must not shrink the map.
std::vector<Vec3> positionsToFit(const MapRenderInput& input) {
  std::vector<Vec3> fitted = input.trajectory;
  for (const auto& keyframe : input.keyframes) fitted.push_back(keyframe.T_wc.t);
  for (const auto& object : input.objects) {
    fitted.push_back(object.box_min);
    fitted.push_back(object.box_max);
  }
  if (!input.points.empty()) {
    Vec3 low, high;
    for (int axis = 0; axis < 3; ++axis) {
      std::vector<double> values;
      for (const auto& point : input.points) values.push_back(point.position[axis]);
      const size_t low_index = values.size() * 2 / 100, high_index = values.size() - 1 - low_index;
      std::nth_element(values.begin(), values.begin() + low_index, values.end());
      low[axis] = values[low_index];
      std::nth_element(values.begin(), values.begin() + high_index, values.end());
      high[axis] = values[high_index];
    }
    for (const auto& point : input.points)
      if ((point.position.array() >= low.array()).all() && (point.position.array() <= high.array()).all())
        fitted.push_back(point.position);
  }
  if (fitted.empty()) fitted.push_back(Vec3::Zero());
  return fitted;
}

double sceneDiagonal(const std::vector<Vec3>& positions) {
  Vec3 low = positions.front(), high = positions.front();
  for (const Vec3& p : positions) {
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  return std::max((high - low).norm(), 0.05);
}

// Pyramid from the camera centre to a 4:3 rectangle `depth` ahead, plus a
// tick on the top edge so "up" in the image is readable.
std::vector<Vec3> frustumSegments(const SE3& T_wc, double depth) {
  const double half_w = 0.5 * depth, half_h = 0.375 * depth;
  const Vec3 centre = T_wc.t;
  const Vec3 corners[4] = {T_wc * Vec3(-half_w, -half_h, depth), T_wc * Vec3(half_w, -half_h, depth),
                           T_wc * Vec3(half_w, half_h, depth), T_wc * Vec3(-half_w, half_h, depth)};
  std::vector<Vec3> segments;
  for (int i = 0; i < 4; ++i) {
    segments.push_back(centre);
    segments.push_back(corners[i]);
    segments.push_back(corners[i]);
    segments.push_back(corners[(i + 1) % 4]);
  }
  return segments;
}

std::array<Vec3, 8> boxCorners(const MapRenderObject& object) {
  std::array<Vec3, 8> corners;
  for (int i = 0; i < 8; ++i)
    corners[i] = Vec3(i & 1 ? object.box_max.x() : object.box_min.x(), i & 2 ? object.box_max.y() : object.box_min.y(),
                      i & 4 ? object.box_max.z() : object.box_min.z());
  return corners;
}

std::vector<Vec3> boxSegments(const MapRenderObject& object) {
  const std::array<Vec3, 8> corners = boxCorners(object);
  std::vector<Vec3> segments;
  // Corners i and j share an edge when their indices differ in exactly one bit.
  for (int i = 0; i < 8; ++i)
    for (int bit : {1, 2, 4})
      if (!(i & bit)) {
        segments.push_back(corners[i]);
        segments.push_back(corners[i | bit]);
      }
  return segments;
}

void drawPointCloud(PlotCanvas& canvas, const MapRenderInput& input, MapColouring colouring) {
  std::vector<Vec3> positions;
  std::vector<cv::Scalar> colours;
  if (colouring == MapColouring::ImageColour) {
    for (const auto& point : input.points) {
      positions.push_back(point.position);
      colours.emplace_back(point.bgr[0], point.bgr[1], point.bgr[2]);
    }
    canvas.drawPoints(positions, colours, 2.5);
    return;
  }
  // Unlabelled first and small, then the labelled ones larger and on top.
  for (const auto& point : input.points)
    if (point.class_id < 0) positions.push_back(point.position);
  canvas.drawPoints(positions, std::vector<cv::Scalar>(positions.size(), kUnlabelledGrey), 2.0);
  positions.clear();
  std::map<int, cv::Scalar> colour_of_class;
  for (const auto& point : input.points) {
    if (point.class_id < 0) continue;
    auto it = colour_of_class.find(point.class_id);
    if (it == colour_of_class.end()) it = colour_of_class.emplace(point.class_id, classColour(point.class_id)).first;
    positions.push_back(point.position);
    colours.push_back(it->second);
  }
  canvas.drawPoints(positions, colours, 4.0);
}

void drawObjectLabels(cv::Mat& image, const PlotProjection& projection, const MapRenderInput& input) {
  for (const auto& object : input.objects) {
    // The box corner highest in the image carries the label.
    bool found = false;
    cv::Point2d top;
    for (const Vec3& corner : boxCorners(object)) {
      if (!projection.inFront(corner)) continue;
      const cv::Point2d px = projection.toPixel(corner);
      if (!found || px.y < top.y) top = px;
      found = true;
    }
    if (found)
      drawLabel(image, object.label, {static_cast<int>(std::lround(top.x)) + 3, static_cast<int>(std::lround(top.y)) - 3},
                classColour(object.class_id));
  }
}

std::vector<LegendEntry> classLegend(const MapRenderInput& input) {
  std::map<int, int> point_count;
  for (const auto& point : input.points)
    if (point.class_id >= 0) ++point_count[point.class_id];
  for (const auto& object : input.objects)
    if (object.class_id >= 0) point_count.emplace(object.class_id, 0);
  std::vector<LegendEntry> legend;
  for (const auto& [class_id, count] : point_count)
    legend.push_back({count > 0 ? cocoClassName(class_id) + " (" + std::to_string(count) + ")" : cocoClassName(class_id),
                      LegendEntry::Sample::Swatch, classColour(class_id)});
  return legend;
}

}  // namespace

cv::Scalar classColour(int class_id) {
  if (class_id < 0) return kUnlabelledGrey;
  const unsigned char* rgb = kClassPalette[class_id % 80];
  return cv::Scalar(rgb[2], rgb[1], rgb[0]);
}

std::string cocoClassName(int class_id) {
  return class_id >= 0 && class_id < 80 ? kCocoNames[class_id] : "class " + std::to_string(class_id);
}

int cocoClassId(const std::string& name) {
  for (int id = 0; id < 80; ++id)
    if (name == kCocoNames[id]) return id;
  return -1;
}

cv::Mat renderMap(const MapRenderInput& input, MapColouring colouring, PlotView view, cv::Size size,
                  PlotProjection* used_projection) {
  const PlotMargins margins;
  const std::vector<Vec3> fitted = positionsToFit(input);
  const double frustum_depth = 0.03 * sceneDiagonal(fitted);
  const cv::Rect area = plotArea(size, margins);

  PlotProjection projection;
  GroundGrid grid;
  double tick_step = 1.0, low_right = 0, high_right = 0, low_up = 0, high_up = 0;
  if (view == PlotView::Top) {
    projection = fitTopView(fitted, size, margins);
    topViewWorldRange(projection, area, low_right, high_right, low_up, high_up);
    tick_step = niceTickStep(std::max(high_right - low_right, high_up - low_up), 8);
  } else {
    grid = groundGridFor(fitted);
    std::vector<Vec3> with_grid = fitted;
    for (const Vec3& corner : grid.corners()) with_grid.push_back(corner);
    projection = fitPerspectiveView(with_grid, size, margins);
  }

  PlotCanvas canvas(projection);
  if (view == PlotView::Top) {
    canvas.clipTo(area);  // stray points must not spill over the axes
    canvas.drawGroundGrid(projection.plane, projection.plane_level, low_right, high_right, low_up, high_up, tick_step,
                          plot_colour::kGrid, 1.0);
  } else {
    drawGroundGrid(canvas, grid);
  }
  canvas.setDepthTest(true);
  drawPointCloud(canvas, input, colouring);
  canvas.drawPolyline(input.trajectory, kTrajectoryColour, 1.5);
  std::vector<Vec3> frusta;
  for (const auto& keyframe : input.keyframes)
    for (const Vec3& p : frustumSegments(keyframe.T_wc, frustum_depth)) frusta.push_back(p);
  canvas.drawSegments(frusta, kKeyframeColour, 1.2);
  for (const auto& object : input.objects) canvas.drawSegments(boxSegments(object), classColour(object.class_id), 3.0);
  cv::Mat image = canvas.finish();

  drawObjectLabels(image, projection, input);
  if (view == PlotView::Top)
    drawTopViewAxes(image, projection, area, tick_step);
  else
    drawGroundGridLabels(image, projection, grid);
  drawTitle(image, input.title);

  std::vector<LegendEntry> legend;
  if (colouring == MapColouring::ImageColour)
    legend.push_back({"map points (image colour)", LegendEntry::Sample::Swatch, cv::Scalar(120, 150, 170)});
  else
    legend.push_back({"unlabelled points", LegendEntry::Sample::Swatch, kUnlabelledGrey});
  if (!input.keyframes.empty()) legend.push_back({"keyframes", LegendEntry::Sample::Frustum, kKeyframeColour});
  if (!input.trajectory.empty()) legend.push_back({"trajectory", LegendEntry::Sample::Line, kTrajectoryColour});
  if (!input.objects.empty()) legend.push_back({"objects (class colour)", LegendEntry::Sample::Line, classColour(input.objects.front().class_id)});
  if (view == PlotView::Perspective) legend.push_back({"grid " + formatLength(grid.step), LegendEntry::Sample::Line, cv::Scalar(205, 205, 205)});
  drawLegendRow(image, legend, 72);

  // Right margin: the classes present, then (top view) the scale bar.
  const int margin_x = area.x + area.width + 30;
  int margin_y = area.y + 10;
  const std::vector<LegendEntry> classes = classLegend(input);
  if (colouring == MapColouring::ObjectClass && !classes.empty()) {
    drawText(image, "class (points)", {margin_x, margin_y + 10}, 0.55, plot_colour::kInk);
    drawLegendColumn(image, classes, {margin_x, margin_y + 22});
    margin_y += 22 + 24 * static_cast<int>(classes.size()) + 40;
  }
  if (view == PlotView::Top) {
    const double pixels_per_m =
        projection.toPixel(Vec3::Unit(projection.plane.right)).x - projection.toPixel(Vec3::Zero()).x;
    drawText(image, "scale", {margin_x, margin_y + 20}, 0.55, plot_colour::kInk);
    drawScaleBar(image, {margin_x, margin_y + 50}, margins.right - 50, pixels_per_m);
  }
  if (used_projection) *used_projection = projection;
  return image;
}

void writeMapRenders(const MapRenderInput& input, const std::string& out_dir) {
  std::filesystem::create_directories(out_dir);
  struct Figure { const char* name; MapColouring colouring; PlotView view; };
  for (const Figure& figure : {Figure{"map_colour.png", MapColouring::ImageColour, PlotView::Perspective},
                               Figure{"map_classes.png", MapColouring::ObjectClass, PlotView::Perspective},
                               Figure{"map_top.png", MapColouring::ObjectClass, PlotView::Top}}) {
    const std::string path = (std::filesystem::path(out_dir) / figure.name).string();
    if (!cv::imwrite(path, renderMap(input, figure.colouring, figure.view)))
      throw std::runtime_error(path + ": cannot write the PNG");
  }
}

}  // namespace vslam
