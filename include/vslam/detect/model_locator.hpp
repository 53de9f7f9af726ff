#pragma once
// Finds a detector's cfg, weights and class-name files by model name.
//
// Search rule (each of the three files is looked for on its own, so a cfg may
// come from ../shared/models/darknet-cfg while its weights sit in ./models):
//   roots, in order: $VSLAM_MODELS (when set), ./models, ../shared/models, then
//   the same two folders beside the source tree (so build/vslam finds them too);
//   in each root: the root itself, then its immediate subfolders in name order.
// The first existing file wins, except that a class-names file beside the
// cfg found is preferred (it belongs to that model). Explicit paths (DetectorParams::cfg, weights,
// names, i.e. --detector-cfg/--detector-weights/--detector-names) bypass the
// search and must exist.
#include <string>
#include <vector>

#include "vslam/core/config.hpp"

namespace vslam {

struct ModelFiles {
  std::string name;     // model name; "custom" when the cfg used is not that model's cfg file
  std::string cfg;
  std::string weights;
  std::string names;
};

// A model `vslam` knows by name: the file names of its release.
struct KnownModel {
  std::string name;
  std::string cfg_file;
  std::string weights_file;
  std::string names_file;
};

const std::vector<KnownModel>& knownModels();

// The roots searched, in order (existing or not).
std::vector<std::string> modelSearchRoots();

// Resolves params.model (or the explicit paths) to existing files. Throws
// InputError for an unknown model name (listing the known ones) or a file
// that cannot be found (saying where it looked and how to fetch it).
// Must not be called with params.model == "none".
ModelFiles locateModel(const DetectorParams& params);

// The name a run with these parameters is reported under, without looking for
// the files: the model's name, or "custom" when the cfg given is not that
// model's cfg file; "none" for no detector. locateModel gives the same name.
std::string runModelName(const DetectorParams& params);

// The cfg alone, by the same rule (for a model whose weights are not at hand).
std::string locateModelCfg(const DetectorParams& params);

}  // namespace vslam
