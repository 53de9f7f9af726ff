#pragma once
// The detector options `vslam run` and `vslam detect` share. They are parsed
// into DetectorOptions first and applied on top of the configuration after it
// is loaded, so the command line overrides the config file.
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "vslam/core/config.hpp"

namespace vslam::app {

struct DetectorOptions {
  std::optional<std::string> model;  // a known name, or "none" to turn detection off
  std::optional<std::string> cfg, weights, names;
  std::optional<int> input_size;
  std::optional<double> confidence, nms;
  std::optional<int> min_box_px;
  std::optional<int> box_features;
  std::optional<std::string> dnn_target;
  std::optional<std::vector<std::string>> dynamic_classes;
  std::optional<std::vector<std::string>> moving_classes;
  std::optional<std::string> detect_every;
  std::optional<int> max_box_age;
  std::optional<int> dnn_threads;
  std::optional<std::string> box_filter;
};

void addDetectorOptions(CLI::App& command, DetectorOptions& options);

// Overrides the fields given on the command line; throws InputError naming
// the option for a value out of range (e.g. --detect-every 0).
void applyDetectorOptions(const DetectorOptions& options, DetectorParams& params);

}  // namespace vslam::app
