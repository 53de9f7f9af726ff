// `vslam synth --out DIR`: a synthetic sequence with a true loop (a camera
// circling inside a textured room, drawn off-screen), in TUM RGB-D layout with
// its rendered depth, ground truth and camera, for testing and benchmarking
// loop closing, monocular or RGB-D.
#include <iostream>
#include <memory>

#include <spdlog/spdlog.h>

#include "commands.hpp"
#include "vslam/core/error.hpp"
#include "vslam/render/room_loop.hpp"

namespace vslam::app {

Command addSynthCommand(CLI::App& app) {
  struct Options {
    std::string out;
    RoomLoopParams room;
  };
  auto options = std::make_shared<Options>();
  Command command;
  command.cli = app.add_subcommand(
      "synth", "Render a synthetic loop sequence (camera circling inside a textured room) in TUM RGB-D layout");
  command.cli->add_option("--out", options->out, "Folder to write (rgb/, depth/, rgb.txt, depth.txt, groundtruth.txt, camera.yaml)")
      ->required();
  command.cli->add_option("--frames", options->room.frames, "Number of frames")->capture_default_str();
  command.cli->add_option("--turns", options->room.turns, "Turns around the room (> 1 revisits the start)")
      ->capture_default_str();
  command.cli->add_option("--radius", options->room.path_radius_m, "Radius of the camera's circle, metres")
      ->capture_default_str();
  command.cli->add_option("--seed", options->room.seed, "Seed of the panel textures")->capture_default_str();
  command.cli->add_option("--moving-object", options->room.moving_object_image,
                          "An image (e.g. a photo of a person) shown on a billboard that walks across the view "
                          "during frames 60-210, for testing moving-object handling; its path goes to moving_object.txt");
  command.cli->add_option("--moving-object-width", options->room.moving_object_width_m,
                          "The billboard's width in metres (its height follows the image's aspect ratio)")
      ->capture_default_str();
  command.run = [options] {
    const RoomLoopParams& room = options->room;
    if (room.frames < 2) throw InputError("--frames must be at least 2");
    if (room.turns <= 0) throw InputError("--turns must be positive");
    if (!(room.moving_object_width_m > 0 && room.moving_object_width_m < 2 * room.room_half_width_m))
      throw InputError("--moving-object-width must lie in (0, " + std::to_string(2 * room.room_half_width_m) + ") m");
    if (room.path_radius_m < 0 || room.path_radius_m > 0.8 * room.room_half_width_m)
      throw InputError("--radius must lie in [0, " + std::to_string(0.8 * room.room_half_width_m) + "] m");
    spdlog::info("rendering {} frames into {}", room.frames, options->out);
    writeRoomLoopSequence(room, options->out, [](int done, int total) {
      if (done % 100 == 0 || done == total) spdlog::info("frame {}/{}", done, total);
    });
    std::cout << "vslam run --seq " << options->out << " --config " << options->out << "/camera.yaml\n";
    return 0;
  };
  return command;
}

}  // namespace vslam::app
