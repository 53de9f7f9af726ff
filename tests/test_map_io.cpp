// Saved maps (map_io/, docs/MAPS.md) on a hand-built map: a save read back and
// saved again gives the same rows; the loaded map has the same keyframes,
// points and graph; and every kind of bad file is refused with one line that
// names it and says why.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "log_capture.hpp"
#include "map_test_support.hpp"

#include "vslam/core/error.hpp"
#include "vslam/map/map.hpp"
#include "vslam/map_io/map_database.hpp"
#include "vslam/map_io/sqlite_database.hpp"
#include "test_support.hpp"

namespace vslam {
namespace {

namespace fs = std::filesystem;

class MapIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    camera_.name = "synthetic";
    camera_.width = 640;
    camera_.height = 480;
    camera_.fx = 517.3;
    camera_.fy = 516.5;
    camera_.cx = 318.6;
    camera_.cy = 255.3;
    camera_.k1 = 0.2624;
    pyramid_ = makeScalePyramid(8, 1.2);
    dir_ = test::scratchDir(std::string("map_io_") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    header_.mode = SensorMode::RgbD;
    header_.camera = camera_;
    header_.vocabulary_checksum = "0123456789abcdef";
    header_.vocabulary_file = "vocab/test.bin";
    header_.sequence = "synthetic";
    header_.created_utc = "2026-12-02T06:00:00Z";
    buildMap();
  }

  Frame makeFrame(long id, int n, double x, bool with_depth) {
    Frame frame;
    frame.id = id;
    frame.index = static_cast<int>(3 * id);
    frame.timestamp = 1305031102.175304 + 0.1 * static_cast<double>(id);
    frame.camera = &camera_;
    frame.pyramid = &pyramid_;
    frame.descriptors = cv::Mat::zeros(n, 32, CV_8U);
    for (int i = 0; i < n; ++i) {
      cv::KeyPoint kp(cv::Point2f(10.25f + 5.f * (i % 100), 10.5f + 5.f * (i / 100)), 31.f * (1 + i % 3),
                      0.37f * static_cast<float>(i), 40.f + i, i % 8);
      frame.keypoints.push_back(kp);
      frame.points.emplace_back(kp.pt.x + 0.125f, kp.pt.y - 0.0625f);
      frame.colours.emplace_back(static_cast<uchar>(i), static_cast<uchar>(2 * i), static_cast<uchar>(id));
      frame.labels.push_back({i % 5 == 0 ? 56 : -1, i % 5 == 0 ? 0 : -1});
      for (int b = 0; b < 32; ++b) frame.descriptors.at<uint8_t>(i, b) = static_cast<uint8_t>(i * 7 + b * 13 + id);
      if (with_depth) {
        frame.depth.push_back(i % 4 == 0 ? -1.0f : 1.0f + 0.01f * static_cast<float>(i));
        frame.u_right.push_back(frame.depth.back() > 0 ? kp.pt.x - 40.f / frame.depth.back() : 0.f);
      }
    }
    frame.T_cw = SE3(Eigen::AngleAxisd(0.1 * static_cast<double>(id), Vec3(0.3, 1, 0.2).normalized()).toRotationMatrix(),
                     Vec3(x, 0.01 * static_cast<double>(id), -0.2));
    frame.finalizeFeatures(cv::Rect2f(0, 0, 640, 480));
    return frame;
  }

  // Five keyframes sharing points along a strip, the fourth culled; a loop
  // edge between the first and the last; bags of words; a few object labels.
  void buildMap() {
    std::vector<KeyFrame*> keyframes;
    for (long k = 0; k < 5; ++k) {
      keyframes.push_back(map_.createKeyFrame(makeFrame(k, 120, 0.1 * static_cast<double>(k), k != 2)));
      KeyFrame* keyframe = keyframes.back();
      // As in a run, each keyframe hangs from the one before (its parent is kept by updateConnections).
      if (k > 0) keyframe->changeParent(keyframes[k - 1]);
      for (int w = 0; w < 10; ++w) keyframe->bow[static_cast<WordId>(100 * k + w)] = 0.1;
      for (int i = 0; i < 120; ++i) keyframe->bow_features[static_cast<NodeId>(i % 7)].push_back(i);
    }
    for (int p = 0; p < 100; ++p) {
      // Point p is seen by keyframes p%3 .. p%3+2 at keypoint p.
      const int first = p % 3;
      MapPoint* point = map_.createMapPoint(Vec3(0.01 * p, -0.02 * p, 2.0 + 0.001 * p), keyframes[first]);
      for (int k = first; k < first + 3; ++k) {
        point->addObservation(keyframes[k], p);
        keyframes[k]->setMapPoint(p, point);
      }
      point->setColour(keyframes[first]->colours[p]);
      point->updateDescriptor();
      point->updateNormalAndDepth(pyramid_);
      point->updateClass();
      point->increaseVisible(p);
      point->increaseFound(p / 2);
      if (p % 2) point->confirm(3);
    }
    for (KeyFrame* keyframe : keyframes) keyframe->updateConnections();
    keyframes[0]->addLoopEdge(keyframes[4]);
    keyframes[4]->addLoopEdge(keyframes[0]);
    keyframes[0]->not_erase = keyframes[4]->not_erase = true;
    keyframes[3]->setBad();
    ASSERT_TRUE(keyframes[3]->isBad());
    objects_.resize(1);
    objects_[0].class_id = 56;
    objects_[0].class_name = "chair";
    objects_[0].confidence = 0.75;
    objects_[0].centroid = Vec3(0.1, 0.2, 2.0);
    objects_[0].box_min = Vec3(0, 0, 1.9);
    objects_[0].box_max = Vec3(0.2, 0.4, 2.1);
    objects_[0].point_ids = {0, 5, 10};
    objects_[0].rejected_point_ids = {15};
    objects_[0].keyframe_ids = {0, 1, 2};
    objects_[0].merged_classes = {"couch"};
    class_names_ = {"person", "bicycle"};
    class_names_.resize(80, "other");
    class_names_[56] = "chair";
  }

  std::string save(const std::string& name) {
    const std::string path = (dir_ / name).string();
    saveMapDatabase(path, map_, header_, objects_, class_names_);
    return path;
  }

  // Runs SQL on a saved file, as a user with the sqlite3 shell would.
  static void edit(const std::string& path, const std::string& sql) {
    SqliteDatabase db(path, SqliteDatabase::Access::Create);
    db.execute(sql);
  }

  // The message of the InputError `load` throws ("" when none).
  std::string refusal(const std::string& path) {
    try {
      const MapFileHeader header = readMapHeader(path);
      Map map;
      std::vector<ObjectLandmark> objects;
      std::vector<std::string> class_names;
      loadMapDatabase(path, map, camera_, pyramid_, &objects, &class_names);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }

  PinholeCamera camera_;
  ScalePyramid pyramid_;
  Map map_;
  MapFileHeader header_;
  std::vector<ObjectLandmark> objects_;
  std::vector<std::string> class_names_;
  fs::path dir_;
};

TEST_F(MapIoTest, SaveLoadSaveGivesTheSameRows) {
  const std::string first = save("first.sqlite");
  const MapFileHeader header = readMapHeader(first);
  Map loaded;
  std::vector<ObjectLandmark> objects;
  std::vector<std::string> class_names;
  loadMapDatabase(first, loaded, camera_, pyramid_, &objects, &class_names);
  const std::string second = (dir_ / "second.sqlite").string();
  saveMapDatabase(second, loaded, header, objects, class_names);
  const auto rows_first = test::mapFileRows(first), rows_second = test::mapFileRows(second);
  ASSERT_EQ(rows_first.size(), 15u);  // every table of schema 1
  for (const auto& [table, rows] : rows_first) EXPECT_EQ(rows, rows_second.at(table)) << table;
  EXPECT_EQ(rows_first.at("keyframes").size(), 4u);   // the culled keyframe is not saved
  EXPECT_EQ(rows_first.at("keypoints").size(), 480u);
  EXPECT_EQ(rows_first.at("map_points").size(), 100u);
  EXPECT_EQ(rows_first.at("loop_edges").size(), 2u);
  EXPECT_EQ(rows_first.at("classes").size(), 80u);
  EXPECT_EQ(rows_first.at("object_points").size(), 4u);
}

TEST_F(MapIoTest, LoadedMapHoldsTheSameKeyFramesPointsAndGraph) {
  const std::string path = save("map.sqlite");
  Map loaded;
  loadMapDatabase(path, loaded, camera_, pyramid_);
  const std::vector<KeyFrame*> before = map_.keyframes(), after = loaded.keyframes();
  ASSERT_EQ(after.size(), before.size());
  for (size_t k = 0; k < before.size(); ++k) {
    const KeyFrame* a = before[k];
    const KeyFrame* b = after[k];
    EXPECT_EQ(b->id(), a->id());
    EXPECT_EQ(b->frameId(), a->frameId());
    EXPECT_EQ(b->frameIndex(), a->frameIndex());
    EXPECT_EQ(b->timestamp(), a->timestamp());
    EXPECT_EQ(b->pose().R, a->pose().R);  // exactly: the 12 numbers of T_cw are stored as doubles
    EXPECT_EQ(b->pose().t, a->pose().t);
    EXPECT_EQ(b->parent() ? b->parent()->id() : -1, a->parent() ? a->parent()->id() : -1);
    EXPECT_EQ(b->not_erase, a->not_erase);
    ASSERT_EQ(b->size(), a->size());
    EXPECT_EQ(cv::norm(a->descriptors, b->descriptors, cv::NORM_HAMMING), 0.0);
    EXPECT_EQ(b->depth, a->depth);
    EXPECT_EQ(b->u_right, a->u_right);
    EXPECT_EQ(b->bow, a->bow);
    EXPECT_EQ(b->bow_features, a->bow_features);
    for (size_t i = 0; i < a->size(); ++i) {
      EXPECT_EQ(b->keypoints[i].pt, a->keypoints[i].pt);
      EXPECT_EQ(b->keypoints[i].octave, a->keypoints[i].octave);
      EXPECT_EQ(b->points[i], a->points[i]);
      EXPECT_EQ(b->colours[i], a->colours[i]);
      EXPECT_EQ(b->labels[i].class_id, a->labels[i].class_id);
      EXPECT_EQ(b->mapPoint(i) ? b->mapPoint(i)->id() : -1, a->mapPoint(i) ? a->mapPoint(i)->id() : -1);
    }
    ASSERT_EQ(b->orderedCovisibles().size(), a->orderedCovisibles().size());
    for (size_t c = 0; c < a->orderedCovisibles().size(); ++c) {
      EXPECT_EQ(b->orderedCovisibles()[c]->id(), a->orderedCovisibles()[c]->id());
      EXPECT_EQ(b->weight(b->orderedCovisibles()[c]), a->weight(a->orderedCovisibles()[c]));
    }
    EXPECT_EQ(b->loopEdges().size(), a->loopEdges().size());
  }
  const std::vector<MapPoint*> points_before = map_.mapPoints(), points_after = loaded.mapPoints();
  ASSERT_EQ(points_after.size(), points_before.size());
  for (size_t p = 0; p < points_before.size(); ++p) {
    const MapPoint* a = points_before[p];
    const MapPoint* b = points_after[p];
    EXPECT_EQ(b->id(), a->id());
    EXPECT_EQ(b->position(), a->position());
    EXPECT_EQ(b->observationWeight(), a->observationWeight());
    EXPECT_EQ(b->reference()->id(), a->reference()->id());
    EXPECT_EQ(b->classId(), a->classId());
    EXPECT_EQ(b->foundRatio(), a->foundRatio());
    EXPECT_EQ(b->confirmed(), a->confirmed());
    EXPECT_EQ(b->minDistance(), a->minDistance());
    EXPECT_EQ(b->normal(), a->normal());
    EXPECT_EQ(cv::norm(a->descriptor(), b->descriptor(), cv::NORM_HAMMING), 0.0);
  }
  // New keyframes and points continue after the loaded ids.
  EXPECT_EQ(loaded.createKeyFrame(makeFrame(9, 10, 0, false))->id(), 5);
}

TEST_F(MapIoTest, SaveReplacesTheFileWholeAndLeavesNoTemporary) {
  const std::string path = save("map.sqlite");
  const auto size_before = fs::file_size(path);
  map_.keyframes()[2]->setBad();  // a smaller map over the old file
  save("map.sqlite");
  EXPECT_LT(fs::file_size(path), size_before);
  EXPECT_EQ(readMapCounts(path).keyframes, 3);
  EXPECT_FALSE(fs::exists(dir_ / ".map.sqlite.partial"));
  for (const auto& entry : fs::directory_iterator(dir_)) EXPECT_EQ(entry.path().filename(), "map.sqlite");
  // An unwritable place: the error names the file, and nothing is left.
  const std::string nowhere = (dir_ / "no_such_folder" / "map.sqlite").string();
  try {
    saveMapDatabase(nowhere, map_, header_, objects_, class_names_);
    FAIL() << "saved into a missing folder";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(nowhere), std::string::npos) << e.what();
  }
}

TEST_F(MapIoTest, CountsAndHeaderAreWhatWasSaved) {
  const std::string path = save("map.sqlite");
  const MapFileHeader header = readMapHeader(path);
  EXPECT_EQ(header.schema_version, kMapSchemaVersion);
  EXPECT_EQ(header.mode, SensorMode::RgbD);
  EXPECT_EQ(header.camera.fx, camera_.fx);
  EXPECT_EQ(header.camera.k1, camera_.k1);
  EXPECT_EQ(header.vocabulary_checksum, "0123456789abcdef");
  const MapFileCounts counts = readMapCounts(path);
  EXPECT_EQ(counts.keyframes, 4);
  EXPECT_EQ(counts.map_points, 100);
  EXPECT_EQ(counts.spanning_tree_edges, 3);
  EXPECT_EQ(counts.loop_edges, 2);
  EXPECT_EQ(counts.objects, 1);
  // Points 0..99 by three keyframes each, less those of the culled keyframe 3 (points with p%3 >= 1).
  EXPECT_EQ(counts.observations, 300 - 66);
}

TEST(MapIoChecksum, VocabularyChecksumIsOfTheFileBytes) {
  const fs::path dir = test::scratchDir("map_io_checksum");
  auto write = [&](const std::string& name, const std::string& bytes) {
    std::ofstream((dir / name).string(), std::ios::binary) << bytes;
    return (dir / name).string();
  };
  // FNV-1a 64 of "a" is af63dc4c8601ec8c (the published test vector).
  EXPECT_EQ(vocabularyChecksum(write("a", "a")), "af63dc4c8601ec8c");
  EXPECT_NE(vocabularyChecksum(write("b", "ab")), vocabularyChecksum(write("c", "ba")));
  EXPECT_EQ(vocabularyChecksum(""), "none");
  EXPECT_THROW(vocabularyChecksum((dir / "missing").string()), InputError);
}

// The one place a run's mode, camera, pyramid and vocabulary become what it
// saves in a map and needs of a map it loads.
TEST(MapIoIdentity, IsTheRunsModeCameraPyramidAndVocabulary) {
  const fs::path dir = test::scratchDir("map_io_identity");
  const std::string vocabulary = (dir / "vocabulary.bin").string();
  std::ofstream(vocabulary, std::ios::binary) << "a";
  Config config;
  config.sensor = SensorMode::RgbD;
  config.camera.name = "synthetic";
  config.camera.fx = 517.3;
  config.camera.bf = 40.0;
  config.orb.n_levels = 6;
  config.orb.scale_factor = 1.3;
  const MapIdentity identity = mapIdentityOf(config, vocabulary);
  EXPECT_EQ(identity.mode, SensorMode::RgbD);
  EXPECT_EQ(identity.camera.name, "synthetic");
  EXPECT_EQ(identity.camera.fx, 517.3);
  EXPECT_EQ(identity.camera.bf, 40.0);
  EXPECT_EQ(identity.orb_levels, 6);
  EXPECT_EQ(identity.orb_scale_factor, 1.3);
  EXPECT_EQ(identity.vocabulary_checksum, "af63dc4c8601ec8c");
  EXPECT_EQ(mapIdentityOf(config, "").vocabulary_checksum, "none");
  // A header made from it is what the same run accepts.
  EXPECT_NO_THROW(checkMapCompatible("map.sqlite", MapFileHeader(identity), identity));
}

// ---- refusals: each names the file and says why, in one line ----

TEST_F(MapIoTest, RefusesAMissingFile) {
  const std::string path = (dir_ / "missing.sqlite").string();
  EXPECT_EQ(refusal(path), path + ": no such map file");
}

TEST_F(MapIoTest, RefusesAFileThatIsNotSqlite) {
  const std::string path = (dir_ / "text.sqlite").string();
  std::ofstream(path) << "this is not a database, it is a text file long enough to have a header\n";
  const std::string message = refusal(path);
  EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
  EXPECT_NE(message.find("not a database"), std::string::npos) << message;
}

TEST_F(MapIoTest, RefusesATruncatedFile) {
  const std::string path = save("truncated.sqlite");
  fs::resize_file(path, fs::file_size(path) / 2);
  const std::string message = refusal(path);
  EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
  EXPECT_NE(message.find("corrupt"), std::string::npos) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
}

TEST_F(MapIoTest, RefusesACorruptFile) {
  const std::string path = save("corrupt.sqlite");
  {
    // Overwrite a stretch in the middle of the file (inside some table's pages).
    std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(static_cast<std::streamoff>(fs::file_size(path) / 2));
    const std::string garbage(3000, '\xA5');
    file.write(garbage.data(), static_cast<std::streamsize>(garbage.size()));
  }
  const std::string message = refusal(path);
  EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
  EXPECT_NE(message.find("corrupt"), std::string::npos) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
}

TEST_F(MapIoTest, RefusesANewerSchema) {
  const std::string path = save("newer.sqlite");
  edit(path, "UPDATE map_info SET value = '2' WHERE key = 'schema_version'");
  EXPECT_EQ(refusal(path), path + ": map schema version 2 is newer than this vslam reads (up to 1): update vslam");
}

TEST_F(MapIoTest, RefusesAnSqliteFileThatIsNotAMap) {
  const std::string path = (dir_ / "other.sqlite").string();
  edit(path, "CREATE TABLE people(name TEXT)");
  EXPECT_EQ(refusal(path), path + ": not a vslam map (no table map_info)");
}

TEST_F(MapIoTest, RefusesAnotherCameraModeOrVocabulary) {
  const std::string path = save("map.sqlite");
  const MapFileHeader header = readMapHeader(path);
  MapIdentity required;
  required.mode = SensorMode::RgbD;
  required.camera = camera_;
  required.vocabulary_checksum = "0123456789abcdef";
  EXPECT_NO_THROW(checkMapCompatible(path, header, required));
  auto message = [&](const MapIdentity& changed) {
    try {
      checkMapCompatible(path, header, changed);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  MapIdentity camera = required;
  camera.camera.fx += 1.0;
  EXPECT_EQ(message(camera).rfind(path + ": the map was made with another camera (synthetic 640x480 fx 517.3 ", 0), 0u)
      << message(camera);
  MapIdentity mode = required;
  mode.mode = SensorMode::Monocular;
  EXPECT_EQ(message(mode), path + ": the map was made in rgbd mode, this run is mono");
  MapIdentity vocabulary = required;
  vocabulary.vocabulary_checksum = "fedcba9876543210";
  EXPECT_EQ(message(vocabulary), path + ": the map was made with another vocabulary (checksum 0123456789abcdef from "
                                        "vocab/test.bin; this run's is fedcba9876543210)");
  MapIdentity pyramid = required;
  pyramid.orb_levels = 4;
  EXPECT_EQ(message(pyramid).rfind(path + ": the map was made with another ORB pyramid (8 levels", 0), 0u)
      << message(pyramid);
}

TEST_F(MapIoTest, RefusesInconsistentLinks) {
  struct Case {
    const char* sql;
    const char* reason;
  };
  const std::vector<Case> cases = {
      {"UPDATE observations SET idx = 500 WHERE map_point_id = 0 AND keyframe_id = 0",
       "inconsistent map: map point 0's observation in keyframe 0 names keypoint 500"},
      {"UPDATE observations SET keyframe_id = 77 WHERE map_point_id = 0 AND keyframe_id = 0",
       "inconsistent map: the observations table names keyframe 77, which is not in the map"},
      {"UPDATE observations SET idx = 3 WHERE map_point_id = 0 AND keyframe_id = 0",
       "inconsistent map: map point 3's observation in keyframe 0: keypoint 3 already holds map point 0"},
      {"UPDATE keyframes SET parent_id = NULL WHERE id = 2", "inconsistent map: the spanning tree has 2 roots, not 1"},
      {"UPDATE keyframes SET parent_id = 4 WHERE id = 1; UPDATE keyframes SET parent_id = 1 WHERE id = 4",
       "inconsistent map: the spanning tree has a cycle through keyframe 1"},
      {"DELETE FROM keypoints WHERE keyframe_id = 1 AND idx = 119",
       "inconsistent map: keyframe 1 has 119 keypoints, keypoint_count says 120"},
      {"UPDATE keypoints SET descriptor = x'00' WHERE keyframe_id = 0 AND idx = 3",
       "keyframe 0 has a descriptor of 1 bytes, not 32"},
      {"DELETE FROM observations WHERE map_point_id = 3", "inconsistent map: map point 3 has no observation"},
      {"DELETE FROM keyframes", "the map has no keyframes (the run that saved it never initialised)"},
  };
  for (size_t c = 0; c < cases.size(); ++c) {
    const std::string path = save("case" + std::to_string(c) + ".sqlite");
    edit(path, cases[c].sql);
    EXPECT_EQ(refusal(path), path + ": " + cases[c].reason) << cases[c].sql;
  }
}

// A damaged schema (found by the random damage below, 4000 copies): SQLite
// quotes the broken CREATE TABLE, newline included, and a primary key that is
// no longer one gives every row the same id. Both are refused in one line (the
// second, once refused by the loader's id check, now by the column check).
TEST_F(MapIoTest, RefusesADamagedSchemaInOneLine) {
  const std::string quoted_newline = save("newline.sqlite");
  edit(quoted_newline,
       "PRAGMA writable_schema = ON; UPDATE sqlite_master SET sql = 'CREATE TABLE covisibility(keyframe_id '' ' || "
       "char(10) || ' other)' WHERE name = 'covisibility'");
  const std::string message = refusal(quoted_newline);
  EXPECT_EQ(message.rfind(quoted_newline + ": corrupt map file (SQLite: malformed database schema (covisibility)", 0), 0u)
      << message;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;

  const std::string no_primary_key = save("no_primary_key.sqlite");
  edit(no_primary_key,
       "PRAGMA writable_schema = ON; UPDATE sqlite_master SET sql = replace(sql, 'id INTEGER PRIMARY KEY, x REAL', "
       "'id INTEGER, x REAL') WHERE name = 'map_points'");
  EXPECT_EQ(refusal(no_primary_key), no_primary_key + ": the map's tables are not as vslam writes them: column 1 of "
                                                      "map_points is 'id INTEGER', not 'id INTEGER PRIMARY KEY 1'");
}

// Ids near the end of `long` (found reading the loader beside the map_file
// fuzz target, which confirmed it under UBSan): Map::restoreKeyFrame's next id
// overflowed, and a run goes on counting from the loaded ids and subtracting
// them. A file consistent in every link but such an id is refused.
TEST_F(MapIoTest, RefusesIdsTooLargeToCountOn) {
  struct Case {
    std::string sql;
    std::string reason;
  };
  const std::string max = "9223372036854775807", min = "-9223372036854775808";
  std::string rename_keyframe;  // keyframe 4, the last, everywhere it is named
  for (const char* column : {"keyframes SET id = %s WHERE id", "keyframes SET parent_id = %s WHERE parent_id",
                             "keypoints SET keyframe_id = %s WHERE keyframe_id",
                             "bow_words SET keyframe_id = %s WHERE keyframe_id",
                             "bow_features SET keyframe_id = %s WHERE keyframe_id",
                             "map_points SET reference_keyframe_id = %s WHERE reference_keyframe_id",
                             "observations SET keyframe_id = %s WHERE keyframe_id",
                             "covisibility SET keyframe_id = %s WHERE keyframe_id",
                             "covisibility SET other_id = %s WHERE other_id",
                             "loop_edges SET keyframe_id = %s WHERE keyframe_id", "loop_edges SET other_id = %s WHERE other_id"}) {
    std::string statement = std::string("UPDATE ") + column + " = 4; ";
    statement.replace(statement.find("%s"), 2, max);
    rename_keyframe += statement;
  }
  const std::vector<Case> cases = {
      {rename_keyframe, "keyframe id " + max + " is out of range (0..1099511627776)"},
      {"UPDATE map_points SET id = " + max + " WHERE id = 99; UPDATE observations SET map_point_id = " + max +
           " WHERE map_point_id = 99",
       "map point id " + max + " is out of range (0..1099511627776)"},
      {"UPDATE map_points SET first_keyframe_id = " + min + " WHERE id = 7",
       "map point 7's first_keyframe_id " + min + " is out of range (0..1099511627776)"},
      {"UPDATE keyframes SET frame_id = -1 WHERE id = 2", "keyframe 2's frame_id -1 is out of range (0..1099511627776)"},
  };
  for (size_t c = 0; c < cases.size(); ++c) {
    const std::string path = save("case" + std::to_string(c) + ".sqlite");
    edit(path, cases[c].sql);
    EXPECT_EQ(refusal(path), path + ": " + cases[c].reason) << cases[c].sql;
  }
}

// A schema that computes a column (found reading the loader beside the map_file
// fuzz target, which timed out on it: 38 s; a Release `vslam run --load-map`
// peaked at 1.9 GB before its refusal): every keypoint's descriptor became
// zeroblob(N), built by SQLite and copied by us. The column check now refuses
// such a schema before any row is read; SQLite still refuses any value over
// 1 MB in a file read as a map, a stored one too (a map's longest is a path).
TEST_F(MapIoTest, RefusesComputedValuesLargerThanAnyAMapHolds) {
  const std::string path = save("computed.sqlite");
  edit(path,
       "PRAGMA writable_schema = ON; UPDATE sqlite_master SET sql = replace(sql, 'descriptor BLOB NOT NULL', "
       "'descriptor BLOB AS (zeroblob(100000000))') WHERE name = 'keypoints'");
  EXPECT_EQ(refusal(path), path + ": the map's tables are not as vslam writes them: column 18 of keypoints is "
                                  "'descriptor BLOB GENERATED VIRTUAL', not 'descriptor BLOB NOT NULL'");
  const std::string stored = save("stored.sqlite");
  edit(stored, "UPDATE map_info SET value = printf('%.*c', 2000000, 'x') WHERE key = 'sequence'");
  EXPECT_EQ(refusal(stored), stored + ": SQLite: step: string or blob too big");
}

// SQLite keeps 64-bit integers, and the loader cast them to int (or to a
// byte): 2^32 + 1 became 1, inside every range checked after the cast. Each
// value too large for its column is refused whole, with its row.
TEST_F(MapIoTest, RefusesIntegersOutsideTheirColumnsRange) {
  struct Case {
    std::string sql;
    std::string reason;
  };
  const std::string ints = ", out of range (-2147483648..2147483647)";
  const std::vector<Case> cases = {
      {"UPDATE keypoints SET octave = 4294967297 WHERE keyframe_id = 1 AND idx = 3",
       "keyframe 1's keypoint 3's octave is 4294967297, out of range (0..7)"},
      {"UPDATE keypoints SET class_id = 4294967295 WHERE keyframe_id = 1 AND idx = 3",
       "keyframe 1's keypoint 3's class_id is 4294967295" + ints},
      {"UPDATE keypoints SET red = 256 WHERE keyframe_id = 1 AND idx = 3",
       "keyframe 1's keypoint 3's red is 256, out of range (0..255)"},
      {"UPDATE keyframes SET frame_index = 4294967302 WHERE id = 2", "keyframe 2's frame_index is 4294967302" + ints},
      {"UPDATE camera SET width = 4294967936", "the camera's width is 4294967936" + ints},
      {"UPDATE bow_words SET word_id = 4294967346 WHERE keyframe_id = 0 AND word_id = 5",
       "keyframe 0's bow word_id is 4294967346, out of range (0..4294967295)"},
      {"UPDATE bow_features SET node_id = -1 WHERE keyframe_id = 0 AND node_id = 0 AND idx = 0",
       "keyframe 0's bow node_id is -1, out of range (0..4294967295)"},
      {"UPDATE map_points SET visible = 4294967301 WHERE id = 7", "map point 7's visible is 4294967301" + ints},
      {"UPDATE map_points SET green = -1 WHERE id = 7", "map point 7's green is -1, out of range (0..255)"},
      {"UPDATE covisibility SET weight = 8589934592 WHERE keyframe_id = 0 AND other_id = 1",
       "the covisibility weight of keyframe 0 with keyframe 1 is 8589934592" + ints},
      {"UPDATE objects SET class_id = 4294967352 WHERE id = 0", "object 0's class_id is 4294967352" + ints},
  };
  for (size_t c = 0; c < cases.size(); ++c) {
    const std::string path = save("case" + std::to_string(c) + ".sqlite");
    edit(path, cases[c].sql);
    EXPECT_EQ(refusal(path), path + ": " + cases[c].reason) << cases[c].sql;
  }
}

// Loads `path` with the fixture's camera and returns its objects, and what the
// loader logged meanwhile in `log`.
std::vector<ObjectLandmark> loadObjectsLogging(const std::string& path, const PinholeCamera& camera,
                                               const ScalePyramid& pyramid, std::string& log) {
  Map loaded;
  std::vector<ObjectLandmark> objects;
  const test::CapturedLog captured;
  loadMapDatabase(path, loaded, camera, pyramid, &objects);
  log = captured.text();
  return objects;
}

// object_points may name a map point the file does not hold: maps saved
// before the writer left such members out have them (objects are grouped from
// every live point, but a point that no live keyframe sees, or whose keypoints
// an earlier point holds, is not saved). The loader leaves those rows out, and
// says so.
TEST_F(MapIoTest, LeavesOutObjectPointsThatAreNotInTheMap) {
  const std::string path = save("map.sqlite");
  edit(path, "INSERT INTO object_points VALUES(0, 777, 0); INSERT INTO object_points VALUES(0, 778, 1)");
  std::string log;
  const std::vector<ObjectLandmark> objects = loadObjectsLogging(path, camera_, pyramid_, log);
  ASSERT_EQ(objects.size(), 1u);
  EXPECT_EQ(objects[0].point_ids, (std::vector<long>{0, 5, 10}));
  EXPECT_EQ(objects[0].rejected_point_ids, (std::vector<long>{15}));
  EXPECT_NE(log.find(path + ": 2 object_points rows name map points the map does not hold (the first: object 0, "
                            "point 777); they are left out"),
            std::string::npos)
      << log;
}

// Likewise object_keyframes may name a keyframe the file does not hold (a
// crafted or damaged file: the writer writes none): left out, and said so.
TEST_F(MapIoTest, LeavesOutObjectKeyFramesThatAreNotInTheMap) {
  const std::string path = save("map.sqlite");
  edit(path, "INSERT INTO object_keyframes VALUES(0, 3); INSERT INTO object_keyframes VALUES(0, 777)");
  std::string log;
  const std::vector<ObjectLandmark> objects = loadObjectsLogging(path, camera_, pyramid_, log);
  ASSERT_EQ(objects.size(), 1u);
  EXPECT_EQ(objects[0].keyframe_ids, (std::vector<long>{0, 1, 2}));
  EXPECT_NE(log.find(path + ": 2 object_keyframes rows name keyframes the map does not hold (the first: object 0, "
                            "keyframe 3); they are left out"),
            std::string::npos)
      << log;
}

// Objects are grouped from every live point (and a point culled after the
// grouping is still named), while the writer saves only the points a live
// keyframe sees: the file must still name no point or keyframe it does not hold.
TEST_F(MapIoTest, WritesNoObjectMemberTheFileDoesNotHold) {
  KeyFrame* culled = map_.keyFrameById(3);
  ASSERT_TRUE(culled->isBad());
  MapPoint* unseen = map_.createMapPoint(Vec3(0.5, 0.5, 2.0), culled);  // live, but seen only by the culled keyframe
  unseen->addObservation(culled, 119);
  objects_[0].point_ids = {0, 5, 10, unseen->id(), 777};
  objects_[0].rejected_point_ids = {15, 778};
  objects_[0].keyframe_ids = {0, 1, 2, culled->id(), 99};
  const std::string path = save("map.sqlite");
  SqliteDatabase db(path, SqliteDatabase::Access::ReadOnly);
  EXPECT_EQ(db.queryInteger("SELECT COUNT(*) FROM object_points WHERE map_point_id NOT IN (SELECT id FROM map_points)"),
            0);
  EXPECT_EQ(db.queryInteger("SELECT COUNT(*) FROM object_keyframes WHERE keyframe_id NOT IN (SELECT id FROM keyframes)"),
            0);
  // The members the file holds are all there.
  EXPECT_EQ(db.queryInteger("SELECT COUNT(*) FROM object_points WHERE rejected = 0"), 3);
  EXPECT_EQ(db.queryInteger("SELECT COUNT(*) FROM object_points WHERE rejected = 1"), 1);
  EXPECT_EQ(db.queryInteger("SELECT COUNT(*) FROM object_keyframes"), 3);
}

// A map's schema is data too: a crafted file could compute a column (SQLite
// runs the expression on every read), hide a view or a trigger, or turn a
// table into a virtual one. Every table must have exactly the columns the
// writer creates, and there must be no views or triggers.
TEST_F(MapIoTest, RefusesTablesThatAreNotAsTheWriterMakesThem) {
  struct Case {
    std::string sql;
    std::string reason;
  };
  const std::string differs = "the map's tables are not as vslam writes them: ";
  auto rewrite = [](const std::string& table, const std::string& from, const std::string& to) {
    return "PRAGMA writable_schema = ON; UPDATE sqlite_master SET sql = replace(sql, '" + from + "', '" + to +
           "') WHERE name = '" + table + "'";
  };
  const std::vector<Case> cases = {
      {rewrite("keypoints", "descriptor BLOB NOT NULL", "descriptor BLOB AS (zeroblob(32))"),
       differs + "column 18 of keypoints is 'descriptor BLOB GENERATED VIRTUAL', not 'descriptor BLOB NOT NULL'"},
      {rewrite("keypoints", "octave INTEGER NOT NULL", "octave BLOB NOT NULL"),
       differs + "column 10 of keypoints is 'octave BLOB NOT NULL', not 'octave INTEGER NOT NULL'"},
      {rewrite("map_points", "visible INTEGER NOT NULL", "visible INTEGER"),
       differs + "column 13 of map_points is 'visible INTEGER', not 'visible INTEGER NOT NULL'"},
      {"ALTER TABLE camera ADD COLUMN note TEXT", differs + "camera has 18 columns, not 17"},
      {"DROP TABLE bow_words; CREATE VIRTUAL TABLE bow_words USING fts5(keyframe_id, word_id, weight)",
       differs + "bow_words is a virtual table"},
      {"CREATE VIEW keyframe_count AS SELECT COUNT(*) FROM keyframes",
       "the map has a view named keyframe_count (vslam writes no views or triggers)"},
      {"CREATE TRIGGER classes_added AFTER INSERT ON classes BEGIN SELECT 1; END",
       "the map has a trigger named classes_added (vslam writes no views or triggers)"},
  };
  for (size_t c = 0; c < cases.size(); ++c) {
    const std::string path = save("case" + std::to_string(c) + ".sqlite");
    edit(path, cases[c].sql);
    EXPECT_EQ(refusal(path), path + ": " + cases[c].reason) << cases[c].sql;
  }
}

// Functions a crafted schema names (in a CHECK constraint or an index, which
// SQLite evaluates while checking the file) run only when SQLite deems them
// harmless: a map is read with trusted_schema off.
TEST_F(MapIoTest, ReadsMapsWithAnUntrustedSchema) {
  const std::string path = save("map.sqlite");
  SqliteDatabase db(path, SqliteDatabase::Access::ReadOnly);
  EXPECT_EQ(db.queryInteger("PRAGMA trusted_schema"), 0);
}

// Random damage, as a disk or a bad copy does it: bytes overwritten anywhere in
// the file. Every damaged copy is either loaded or refused with an InputError
// of one line; never a crash or another exception (a small, deterministic
// stand-in for a fuzz target: 300 copies, fixed seed).
TEST_F(MapIoTest, RandomlyDamagedFilesAreLoadedOrRefusedNeverCrash) {
  const std::string original = save("original.sqlite");
  std::string bytes;
  {
    std::ifstream in(original, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  std::mt19937 random(17);
  int refused = 0, loaded = 0;
  const std::string path = (dir_ / "damaged.sqlite").string();
  for (int copy = 0; copy < 300; ++copy) {
    std::string damaged = bytes;
    const int changes = 1 + static_cast<int>(random() % 8);
    for (int c = 0; c < changes; ++c) damaged[random() % damaged.size()] = static_cast<char>(random() % 256);
    std::ofstream(path, std::ios::binary | std::ios::trunc) << damaged;
    const std::string message = refusal(path);
    if (message.empty()) {
      ++loaded;
    } else {
      ++refused;
      EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
      EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    }
  }
  std::printf("damaged copies: %d loaded, %d refused\n", loaded, refused);
  EXPECT_GT(refused, 0);
}

}  // namespace
}  // namespace vslam
