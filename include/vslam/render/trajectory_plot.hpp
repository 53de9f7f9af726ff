#pragma once
// Trajectory figures for reports: the aligned estimate coloured by its error
// over the dashed ground truth, as a top view and a 3D perspective.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "vslam/core/types.hpp"
#include "vslam/render/plot_projection.hpp"

namespace vslam {

struct TrajectoryPlotInput {
  std::string title;              // e.g. "tum/fr1_xyz — mono — ATE RMSE 0.94 cm"
  std::vector<Vec3> groundtruth;  // positions (metres), in the ground-truth frame
  std::vector<Vec3> estimate;     // aligned estimate positions, same frame
  std::vector<double> error_m;    // per estimate position (colour map); empty = single colour
};

// Colour of the estimate when there are no errors to show.
const cv::Scalar kEstimateColour(200, 90, 20);  // BGR: strong blue

// Top: orthographic view of the plane chooseTopPlane picks (the one with the
// largest spread), equal axis scale, metre ticks, scale bar. Perspective:
// ground grid (labelled in metres) under the paths, the estimate's shadow on it.
// Both: title, legend, error colour bar (cm). `used_projection`, when given,
// receives the world -> pixel transform of the image.
cv::Mat renderTrajectoryPlot(const TrajectoryPlotInput& input, PlotView view, cv::Size size = {1280, 960},
                             PlotProjection* used_projection = nullptr);

// Writes out_dir/trajectory_top.png and out_dir/trajectory_3d.png (creating
// out_dir). Throws std::runtime_error naming the file when writing fails.
void writeTrajectoryPlots(const TrajectoryPlotInput& input, const std::string& out_dir);

}  // namespace vslam
