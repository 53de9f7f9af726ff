// `vslam eval`: placeholder until the trajectory evaluation lands.
#include "commands.hpp"

namespace vslam::app {

Command addEvalCommand(CLI::App& app) {
  Command command;
  command.cli = app.add_subcommand("eval", "Score an estimated trajectory against ground truth (ATE, RPE)");
  command.run = [] { return 0; };
  return command;
}

}  // namespace vslam::app
