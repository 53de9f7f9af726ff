// `vslam`: one executable, one subcommand per job. Logs go to stderr,
// results to files and stdout.
#include <algorithm>
#include <iostream>
#include <vector>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "vslam/core/error.hpp"

int main(int argc, char** argv) {
  auto logger = spdlog::stderr_color_mt("vslam");
  spdlog::set_default_logger(logger);
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");

  CLI::App app{"vslam: ORB-SLAM-style visual SLAM with a YOLO object detector inside Tracking"};
  app.require_subcommand(1);
  app.set_help_all_flag("--help-all", "Show the help of every subcommand");
  bool verbose = false;
  app.add_flag("-v,--verbose", verbose, "Debug logging");

  std::vector<vslam::app::Command> commands = {
      vslam::app::addRunCommand(app),
      vslam::app::addEvalCommand(app),
      vslam::app::addRenderCommand(app),
      vslam::app::addDetectCommand(app),
      vslam::app::addVocabCommand(app),
      vslam::app::addSynthCommand(app),
      vslam::app::addMapCommand(app),
  };

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --help-all
    // CLI11 would only say that a command is required.
    if (argc > 1 && argv[1][0] != '-' &&
        std::none_of(commands.begin(), commands.end(), [&](const auto& c) { return c.cli->get_name() == argv[1]; })) {
      std::string names;
      for (const auto& command : commands) names += (names.empty() ? "" : ", ") + command.cli->get_name();
      std::cerr << "error: unknown command '" << argv[1] << "' (commands: " << names << ")\n";
      return 2;
    }
    // A bad command line is an input error like any other: one line, exit 2
    // (CLI11's own codes, e.g. 105 for a value out of range, mean nothing to a user).
    std::cerr << "error: " << e.what() << " (see --help)\n";
    return 2;
  }
  if (verbose) spdlog::set_level(spdlog::level::debug);

  try {
    for (const auto& command : commands)
      if (command.cli->parsed()) return command.run();
  } catch (const vslam::InputError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
