#pragma once
// Hamming distance of two 256-bit descriptors held as four 64-bit words
// (private to src/place).
#include <cstdint>

namespace vslam::place {

// Bits set in x, by the classic SWAR reduction. Written out because the
// project builds for baseline x86-64, where __builtin_popcountll becomes a
// library call (no POPCNT instruction) that is several times slower than this.
inline int popcount64(uint64_t x) {
  x = x - ((x >> 1) & 0x5555555555555555ull);
  x = (x & 0x3333333333333333ull) + ((x >> 2) & 0x3333333333333333ull);
  x = (x + (x >> 4)) & 0x0F0F0F0F0F0F0F0Full;
  return static_cast<int>((x * 0x0101010101010101ull) >> 56);
}

inline int hamming256(const uint64_t* a, const uint64_t* b) {
  return popcount64(a[0] ^ b[0]) + popcount64(a[1] ^ b[1]) + popcount64(a[2] ^ b[2]) + popcount64(a[3] ^ b[3]);
}

}  // namespace vslam::place
