#pragma once
// One entry point per reader of outside input, shared by the libFuzzer targets
// (tests/fuzz/fuzz_<name>.cpp, built with -DVSLAM_FUZZ=ON) and by the corpus
// replay in the normal test suite (tests/test_fuzz_corpus_replay.cpp).
//
// Each entry point feeds its bytes to the reader as the text or bytes of one
// file. An InputError (the project's error for bad input) is the expected
// answer to a bad file and is swallowed; anything else escapes: another
// exception, a crash or a sanitizer report is a bug in the reader.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace vslam::fuzz {

// True when the reader accepted the input, false when it threw InputError.
using EntryPoint = bool (*)(const std::uint8_t* data, std::size_t size);

struct FuzzTarget {
  std::string name;  // fuzz_<name> executable, tests/fuzz/corpus/<name>/ seeds
  EntryPoint run;
};

// Every target, in the order tools/fuzz.sh runs them.
const std::vector<FuzzTarget>& fuzzTargets();

// TUM rgb.txt (and, after a form feed '\f', depth.txt), then the colour-depth association.
bool fuzzTumList(const std::uint8_t* data, std::size_t size);
bool fuzzTumTrajectory(const std::uint8_t* data, std::size_t size);  // groundtruth.txt, our trajectory.txt
bool fuzzKittiPoses(const std::uint8_t* data, std::size_t size);     // poses/NN.txt
bool fuzzKittiTimes(const std::uint8_t* data, std::size_t size);     // times.txt
bool fuzzKittiCalib(const std::uint8_t* data, std::size_t size);     // calib.txt
bool fuzzConfig(const std::uint8_t* data, std::size_t size);         // our YAML or an ORB-SLAM2 settings file
// Binary or DBoW2 text vocabulary; an accepted one then turns fixed descriptors into words.
bool fuzzVocabulary(const std::uint8_t* data, std::size_t size);
bool fuzzDarknetCfg(const std::uint8_t* data, std::size_t size);  // a .cfg, then its weights size
// The first bytes of a .weights file, checked against a small fixed cfg for a file of `size` bytes.
bool fuzzDarknetWeights(const std::uint8_t* data, std::size_t size);
bool fuzzPly(const std::uint8_t* data, std::size_t size);            // map.ply
bool fuzzDepthPng(const std::uint8_t* data, std::size_t size);        // a depth image (16-bit PNG)
bool fuzzBundleProblem(const std::uint8_t* data, std::size_t size);  // a recorded bundle problem
// A saved map (SQLite), through a temporary file: what `vslam map info` and
// `vslam run --load-map` read (header, counts, compatibility, the whole map).
bool fuzzMapFile(const std::uint8_t* data, std::size_t size);

}  // namespace vslam::fuzz
