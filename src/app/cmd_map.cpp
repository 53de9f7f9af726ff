// `vslam map info FILE` and `vslam map export FILE --ply OUT`: what a saved map
// (docs/MAPS.md) holds, and its point cloud for viewers.
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include "commands.hpp"
#include "vslam/core/error.hpp"
#include "vslam/io/atomic_file.hpp"
#include "vslam/io/ply.hpp"
#include "vslam/map_io/map_database.hpp"
#include "vslam/map_io/sqlite_database.hpp"

namespace vslam::app {
namespace {

struct MapCommandOptions {
  std::string file;
  std::string ply;
};

int info(const MapCommandOptions& options) {
  const MapFileHeader header = readMapHeader(options.file);
  const MapFileCounts counts = readMapCounts(options.file);
  const PinholeCamera& c = header.camera;
  std::printf("file: %s\n", options.file.c_str());
  std::printf("schema version: %d\n", header.schema_version);
  std::printf("mode: %s\n", toString(header.mode));
  std::printf("sequence: %s\n", header.sequence.c_str());
  std::printf("created: %s\n", header.created_utc.c_str());
  std::printf("camera: %s %dx%d fx %.10g fy %.10g cx %.10g cy %.10g k1 %.10g k2 %.10g p1 %.10g p2 %.10g k3 %.10g bf %.10g\n",
              c.name.c_str(), c.width, c.height, c.fx, c.fy, c.cx, c.cy, c.k1, c.k2, c.p1, c.p2, c.k3, c.bf);
  std::printf("orb pyramid: %d levels, scale %.10g\n", header.orb_levels, header.orb_scale_factor);
  std::printf("vocabulary: %s (checksum %s)\n", header.vocabulary_file.c_str(), header.vocabulary_checksum.c_str());
  std::printf("keyframes: %ld (%ld keypoints)\n", counts.keyframes, counts.keypoints);
  std::printf("map points: %ld (%ld observations)\n", counts.map_points, counts.observations);
  std::printf("covisibility edges: %ld (directed), spanning tree edges: %ld, loop edges: %ld (directed)\n",
              counts.covisibility_edges, counts.spanning_tree_edges, counts.loop_edges);
  std::printf("objects: %ld, class labels: %ld\n", counts.objects, counts.classes);
  return 0;
}

int exportPly(const MapCommandOptions& options) {
  readMapHeader(options.file);  // refuses a corrupt or foreign file first
  SqliteDatabase db(options.file, SqliteDatabase::Access::ReadOnly);
  SqliteStatement rows = db.prepare("SELECT x, y, z, red, green, blue, class_id FROM map_points ORDER BY id");
  std::vector<PlyPoint> cloud;
  while (rows.step()) {
    PlyPoint point;
    point.position = Vec3(rows.real(0), rows.real(1), rows.real(2));
    point.bgr = cv::Vec3b(static_cast<uint8_t>(rows.integer(5)), static_cast<uint8_t>(rows.integer(4)),
                          static_cast<uint8_t>(rows.integer(3)));
    point.class_id = static_cast<int>(rows.integer(6));
    cloud.push_back(point);
  }
  writeFileAtomically(options.ply, [&](const std::string& temporary) { writeMapPly(temporary, cloud); });
  std::printf("wrote %zu map points to %s\n", cloud.size(), options.ply.c_str());
  return 0;
}

}  // namespace

Command addMapCommand(CLI::App& app) {
  auto options = std::make_shared<MapCommandOptions>();
  Command command;
  CLI::App* cli = app.add_subcommand("map", "Inspect or export a map saved with `vslam run --save-map` (docs/MAPS.md)");
  cli->require_subcommand(1);
  CLI::App* info_cli = cli->add_subcommand("info", "Print what a saved map holds");
  info_cli->add_option("file", options->file, "Map file (SQLite)")->required();
  CLI::App* export_cli = cli->add_subcommand("export", "Write a saved map's points as a PLY point cloud");
  export_cli->add_option("file", options->file, "Map file (SQLite)")->required();
  export_cli->add_option("--ply", options->ply, "Output PLY file (the layout of a run folder's map.ply)")->required();
  command.cli = cli;
  command.run = [options, info_cli] { return info_cli->parsed() ? info(*options) : exportPly(*options); };
  return command;
}

}  // namespace vslam::app
