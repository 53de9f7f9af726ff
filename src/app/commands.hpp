#pragma once
// Each `vslam` subcommand lives in its own cmd_<name>.cpp and registers itself
// here: it adds its options to the CLI11 app and returns the action to run
// when it was the one chosen.
#include <functional>

#include <CLI/CLI.hpp>

namespace vslam::app {

struct Command {
  CLI::App* cli = nullptr;
  std::function<int()> run;  // exit status
};

Command addRunCommand(CLI::App& app);
Command addEvalCommand(CLI::App& app);
Command addRenderCommand(CLI::App& app);
Command addDetectCommand(CLI::App& app);
Command addVocabCommand(CLI::App& app);
Command addSynthCommand(CLI::App& app);
Command addMapCommand(CLI::App& app);

}  // namespace vslam::app
