#include "vslam/detect/model_locator.hpp"

#include <algorithm>
#include <cstdlib>
#include <filesystem>

#include "vslam/core/error.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;

std::string joinedNames() {
  std::string list;
  for (const KnownModel& model : knownModels()) list += (list.empty() ? "" : ", ") + model.name;
  return list;
}

// First match of `file_name` under the roots (root, then its subfolders by name).
std::string search(const std::string& file_name) {
  for (const std::string& root : modelSearchRoots()) {
    std::error_code error;
    if (!fs::is_directory(root, error)) continue;
    if (fs::is_regular_file(fs::path(root) / file_name, error)) return (fs::path(root) / file_name).string();
    std::vector<fs::path> subfolders;
    for (const auto& entry : fs::directory_iterator(root, error))
      if (entry.is_directory(error)) subfolders.push_back(entry.path());
    std::sort(subfolders.begin(), subfolders.end());
    for (const fs::path& folder : subfolders)
      if (fs::is_regular_file(folder / file_name, error)) return (folder / file_name).string();
  }
  return "";
}

std::string whereWeLooked() {
  std::string list;
  for (const std::string& root : modelSearchRoots()) list += (list.empty() ? "" : ", ") + root;
  return list + " (and their subfolders)";
}

std::string explicitFile(const std::string& path, const char* option) {
  std::error_code error;
  if (!fs::is_regular_file(path, error))
    throw InputError(path, 0, std::string("file given by ") + option + " does not exist");
  return path;
}

}  // namespace

const std::vector<KnownModel>& knownModels() {
  static const std::vector<KnownModel> models = {
      {"yolo-fastest-1.1-xl", "yolo-fastest-1.1-xl.cfg", "yolo-fastest-1.1-xl.weights", "coco.names"},
      {"yolo-fastest-1.1", "yolo-fastest-1.1.cfg", "yolo-fastest-1.1.weights", "coco.names"},
      {"yolov4", "yolov4.cfg", "yolov4.weights", "coco.names"},
      {"yolov4-tiny", "yolov4-tiny.cfg", "yolov4-tiny.weights", "coco.names"},
  };
  return models;
}

std::vector<std::string> modelSearchRoots() {
  std::vector<std::string> roots;
  if (const char* env = std::getenv("VSLAM_MODELS"); env && *env) roots.emplace_back(env);
  roots.emplace_back("./models");
  roots.emplace_back("../shared/models");
  const fs::path source(VSLAM_SOURCE_DIR);
  for (const fs::path& extra : {source / "models", source.parent_path() / "shared" / "models"}) {
    std::error_code error;
    // Skip duplicates of the cwd-relative roots when running from the source tree.
    const bool duplicate = std::any_of(roots.begin(), roots.end(), [&](const std::string& root) {
      return fs::equivalent(root, extra, error);
    });
    if (!duplicate) roots.push_back(extra.string());
  }
  return roots;
}

namespace {

const KnownModel* knownModel(const std::string& name) {
  const auto known = std::find_if(knownModels().begin(), knownModels().end(),
                                  [&](const KnownModel& model) { return model.name == name; });
  return known == knownModels().end() ? nullptr : &*known;
}

std::string resolveModelFile(const DetectorParams& params, const std::string& explicit_path, const char* option,
                             const std::string& file_name) {
  if (!explicit_path.empty()) return explicitFile(explicit_path, option);
  const std::string found = search(file_name);
  if (found.empty())
    throw InputError(file_name, 0,
                     "not found for detector model '" + params.model + "'; looked in " + whereWeLooked() +
                         "; download it with tools/fetch_models.sh " + params.model + " (or set $VSLAM_MODELS, or give " +
                         option + ")");
  return found;
}

InputError unknownModel(const std::string& name, const std::string& explicit_options) {
  return InputError("unknown detector model '" + name + "' (known: " + joinedNames() + "; or give " +
                    explicit_options + ")");
}

}  // namespace

std::string locateModelCfg(const DetectorParams& params) {
  const KnownModel* known = knownModel(params.model);
  if (!known && params.cfg.empty()) throw unknownModel(params.model, "--detector-cfg");
  return resolveModelFile(params, params.cfg, "--detector-cfg", known ? known->cfg_file : "");
}

ModelFiles locateModel(const DetectorParams& params) {
  ModelFiles files;
  const KnownModel* known = knownModel(params.model);
  const bool fully_explicit = !params.cfg.empty() && !params.weights.empty();
  if (!known && !fully_explicit) throw unknownModel(params.model, "--detector-cfg and --detector-weights");
  files.cfg = locateModelCfg(params);
  files.weights = resolveModelFile(params, params.weights, "--detector-weights", known ? known->weights_file : "");
  // Class names: the file beside the cfg first (it belongs to that model),
  // then the search. A custom model without one gets COCO's: every model here is COCO-trained.
  const std::string names_file = known ? known->names_file : "coco.names";
  const fs::path beside_cfg = fs::path(files.cfg).parent_path() / names_file;
  std::error_code error;
  if (params.names.empty() && fs::is_regular_file(beside_cfg, error))
    files.names = beside_cfg.string();
  else
    files.names = resolveModelFile(params, params.names, "--detector-names", names_file);
  files.name = runModelName(params);
  return files;
}

std::string runModelName(const DetectorParams& params) {
  if (params.model == "none") return params.model;
  // A cfg of another model is not the named model (the default name stays
  // yolo-fastest-1.1-xl when only --detector-cfg and --detector-weights are given).
  const KnownModel* known = knownModel(params.model);
  if (!known || (!params.cfg.empty() && fs::path(params.cfg).filename() != known->cfg_file)) return "custom";
  return params.model;
}

}  // namespace vslam
