// Fast, seedable random numbers for the simulator: xoshiro256+ (Blackman & Vigna) seeded by
// SplitMix64 from a tuple of integers, so that every raw frame and every image row has its own
// stream. Frames then depend only on (seed, sequence), not on how many threads made them or on
// what was generated before, which keeps captures reproducible.
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <numbers>

// The rounding by adding and subtracting 1.5 * 2^52 below (and in sensor.cc) is what
// -ffast-math would fold away.
#ifdef __FAST_MATH__
#error "the simulator's random numbers need IEEE arithmetic: do not build them with -ffast-math"
#endif

namespace transient::sim {

// The natural logarithm of x in [2^-1022, 1] and the sine and cosine of 2 pi u for u in [0, 1],
// in plain arithmetic, their choices made on bits, so that loops over them vectorize (the
// simulator draws several million normals a VGA frame: Sensor::ReadRow). The logarithm within
// a unit in the last place of std::log, sine and cosine within 7.3e-16 of std::sin and std::cos
// (tests/drivers/sim/sensor_noise_test.cc). The same bits wherever their multiply-adds are not
// fused: in this project's builds, which target the baseline x86-64 (no FMA instruction) except
// in sensor.cc's clones, compiled with -ffp-contract=off. Outside the domains the results are
// wrong, not errors (LogOfUnit(0) is -1023 ln 2 rather than -inf). Always inlined: under the
// sanitizers' -O1 Clang called them, and a simulated capture took 1.7x as long as with the C
// library's functions.
//
// log (the argument reduction and the series of fdlibm's e_log.c, with the series' plain
// coefficients): x = 2^e y with y in [sqrt(1/2), sqrt(2)) (e and y from x's bits), f = y - 1
// (exact); with s = f / (2 + f), log(1 + f) = 2 atanh(s) = f - f^2/2 + s (f^2/2 + R),
// R = sum_k 2 s^(2k) / (2k + 1), |s| <= 0.172: twelve terms leave under 1e-19 of it.
[[gnu::always_inline]] inline double LogOfUnit(double x) {
  constexpr uint64_t kSqrtHalf = 0x3fe6a09e667f3bcdULL;  // the bits of sqrt(1/2)
  constexpr uint64_t kBias = 1024ULL << 52;              // keeps the difference positive
  const uint64_t bits = std::bit_cast<uint64_t>(x);
  const uint64_t shifted = bits - kSqrtHalf + kBias;  // (e + 1024) in its top 12 bits
  const double y = std::bit_cast<double>(bits - (shifted & 0xfff0000000000000ULL) + kBias);
  // e + 1024 as a double: its bits in the mantissa of 2^52, less 2^52.
  const double e =
      (std::bit_cast<double>((shifted >> 52) | std::bit_cast<uint64_t>(0x1p52)) - 0x1p52) - 1024.0;
  const double f = y - 1.0;
  const double s = f / (2.0 + f);
  const double z = s * s;
  double r = 2.0 / 25.0;
#pragma GCC unroll 16
  for (int k = 11; k >= 1; --k) r = r * z + 2.0 / (2 * k + 1);
  r *= z;
  const double half_f2 = 0.5 * f * f;
  // ln 2 as a head of 32 bits (e * head is exact) and its tail.
  constexpr double kLn2Head = 0x1.62e42fee00000p-1;
  constexpr double kLn2Tail = std::numbers::ln2 - kLn2Head;
  return e * kLn2Head - ((half_f2 - (s * (half_f2 + r) + e * kLn2Tail)) - f);
}

// sin(2 pi u) and cos(2 pi u) for u in [0, 1]: u = k/4 + t with k = rint(4u) and |t| <= 1/8
// (exact: u and k/4 are multiples of u's last place), the Taylor series of sin x and cos x for
// x = 2 pi t, |x| <= pi/4, to x^19 and x^18 (the terms left are under 1e-18 of the result),
// turned by k quarter turns.
namespace internal {
inline constexpr int kSinCosTerms = 10;
// (-1)^j / (2j + 1)! and (-1)^j / (2j)!
inline constexpr auto kSinCosCoefficients = [] {
  struct {
    double sine[kSinCosTerms], cosine[kSinCosTerms];
  } c{};
  double factorial = 1.0;  // (2j)!
  for (int j = 0; j < kSinCosTerms; ++j) {
    if (j > 0) factorial *= (2.0 * j - 1.0) * (2.0 * j);
    const double sign = j % 2 == 0 ? 1.0 : -1.0;
    c.cosine[j] = sign / factorial;
    c.sine[j] = sign / (factorial * (2.0 * j + 1.0));
  }
  return c;
}();
}  // namespace internal

[[gnu::always_inline]] inline void SinCosOfTurns(double u, double* sine, double* cosine) {
  const double rounded = 4.0 * u + 0x1.8p52;                      // rint(4u) in its last bits
  const uint64_t quarter = std::bit_cast<uint64_t>(rounded) & 3;  // k mod 4
  const double x = 2.0 * std::numbers::pi * (u - 0.25 * (rounded - 0x1.8p52));
  const double x2 = x * x;
  const auto& c = internal::kSinCosCoefficients;
  double sp = c.sine[internal::kSinCosTerms - 1], cp = c.cosine[internal::kSinCosTerms - 1];
#pragma GCC unroll 16
  for (int j = internal::kSinCosTerms - 2; j >= 0; --j) {
    sp = sp * x2 + c.sine[j];
    cp = cp * x2 + c.cosine[j];
  }
  // sin(x + k pi/2), cos(x + k pi/2): swapped for odd k, the sine's sign flipped for k = 2, 3
  // and the cosine's for k = 1, 2.
  const uint64_t s = std::bit_cast<uint64_t>(x * sp), co = std::bit_cast<uint64_t>(cp);
  const uint64_t swap = 0 - (quarter & 1);
  *sine = std::bit_cast<double>(((co & swap) | (s & ~swap)) ^ ((quarter & 2) << 62));
  *cosine = std::bit_cast<double>(((s & swap) | (co & ~swap)) ^ (((quarter + 1) & 2) << 62));
}

// Two independent standard normals from two uniforms, u1 in (0, 1] and u2 in [0, 1)
// (Box-Muller): sqrt(-2 log u1) (cos 2 pi u2, sin 2 pi u2).
[[gnu::always_inline]] inline void BoxMuller(double u1, double u2, double* a, double* b) {
  const double radius = std::sqrt(-2.0 * LogOfUnit(u1));
  double sine, cosine;
  SinCosOfTurns(u2, &sine, &cosine);
  *a = radius * cosine;
  *b = radius * sine;
}

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

  // Uniform in [0, 1) with 53 random bits (of Next()'s `bits`).
  double Uniform() { return UniformOf(Next()); }
  static double UniformOf(uint64_t bits) { return static_cast<double>(bits >> 11) * 0x1.0p-53; }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }

  // Two independent standard normals (Box-Muller).
  void Normals(double* a, double* b) {
    const double u1 = 1.0 - Uniform();  // (0, 1]: log stays finite
    BoxMuller(u1, Uniform(), a, b);
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
