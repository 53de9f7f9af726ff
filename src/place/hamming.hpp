#pragma once
// Hamming distance of two 256-bit descriptors held as four 64-bit words
// (private to src/place).
#include <cstdint>

namespace vslam::place {

inline int hamming256(const uint64_t* a, const uint64_t* b) {
  return __builtin_popcountll(a[0] ^ b[0]) + __builtin_popcountll(a[1] ^ b[1]) +
         __builtin_popcountll(a[2] ^ b[2]) + __builtin_popcountll(a[3] ^ b[3]);
}

}  // namespace vslam::place
