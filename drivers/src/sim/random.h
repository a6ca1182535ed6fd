// Fast, seedable random numbers for the simulator: xoshiro256+ (Blackman & Vigna) seeded by
// SplitMix64 from a tuple of integers, so that every raw frame and every image row has its own
// stream. Frames then depend only on (seed, sequence), not on how many threads made them or on
// what was generated before, which keeps captures reproducible.
#pragma once

#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <numbers>

namespace transient::sim {

inline uint64_t SplitMix64(uint64_t* state) {
  uint64_t z = (*state += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

class Random {
 public:
  // A stream determined by the given keys (e.g. seed, purpose, sequence, row).
  explicit Random(std::initializer_list<uint64_t> keys) {
    uint64_t h = 0x5851f42d4c957f2dULL;
    for (uint64_t k : keys) {
      uint64_t mix = h ^ k;
      h = SplitMix64(&mix);
    }
    for (uint64_t& s : s_) s = SplitMix64(&h);
  }

  uint64_t Next() {
    const uint64_t result = s_[0] + s_[3];
    const uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = (s_[3] << 45) | (s_[3] >> 19);
    return result;
  }

  // Uniform in [0, 1) with 53 random bits.
  double Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }

  // Two independent standard normals (Box-Muller).
  void Normals(double* a, double* b) {
    const double u1 = 1.0 - Uniform();  // (0, 1]: log stays finite
    const double radius = std::sqrt(-2.0 * std::log(u1));
    const double angle = 2.0 * std::numbers::pi * Uniform();
    *a = radius * std::cos(angle);
    *b = radius * std::sin(angle);
  }
  double Normal() {
    double a, b;
    Normals(&a, &b);
    return a;
  }

  // Poisson by multiplication of uniforms (Knuth); meant for small means.
  int Poisson(double mean) {
    const double limit = std::exp(-mean);
    int k = 0;
    double product = Uniform();
    while (product > limit) {
      ++k;
      product *= Uniform();
    }
    return k;
  }

 private:
  uint64_t s_[4];
};

// Purposes, so that the streams of different uses of one seed never coincide.
enum RandomStream : uint64_t {
  kStreamFixedPattern = 1,
  kStreamScene = 2,
  kStreamNoise = 3,
  kStreamOutlier = 4,
};

}  // namespace transient::sim
