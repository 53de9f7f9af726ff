// `vslam run`: placeholder until the sequence readers land.
#include "commands.hpp"

namespace vslam::app {

Command addRunCommand(CLI::App& app) {
  Command command;
  command.cli = app.add_subcommand("run", "Run SLAM on a sequence");
  command.run = [] { return 0; };
  return command;
}

}  // namespace vslam::app
