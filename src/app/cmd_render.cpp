// `vslam render RUN_DIR [--out DIR]`: the report figures of a finished run.
#include <iostream>
#include <memory>

#include "commands.hpp"
#include "vslam/render/run_renders.hpp"

namespace vslam::app {

Command addRenderCommand(CLI::App& app) {
  struct Options {
    std::string run_dir;
    std::string out_dir;  // empty: the run folder itself
  };
  auto options = std::make_shared<Options>();
  Command command;
  command.cli = app.add_subcommand("render", "Write trajectory and map figures (PNG) for a run folder");
  command.cli->add_option("RUN_DIR", options->run_dir, "Run folder (trajectory.txt, map.ply, objects.json, ...)")
      ->required();
  command.cli->add_option("--out", options->out_dir, "Folder for the PNGs (default: RUN_DIR)");
  command.run = [options] {
    const std::string out_dir = options->out_dir.empty() ? options->run_dir : options->out_dir;
    for (const std::string& path : renderRunFolder(options->run_dir, out_dir)) std::cout << path << "\n";
    return 0;
  };
  return command;
}

}  // namespace vslam::app
