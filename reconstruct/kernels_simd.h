// Eight doubles at a time in GCC's generic vectors (also understood by Clang), for the
// optimized kernels' per-pixel work that the auto-vectorizer does not take on (Newton steps
// with per-lane masks, Levinson's recursion). A kernel is compiled once per instruction set
// (TRANSIENT_SIMD_VARIANTS below): one AVX-512 register, two AVX2 ones or four SSE2 ones per
// vector. Not with target_clones: GCC 12 lowers a clone's generic vector comparisons for the
// baseline instruction set, one scalar comparison per lane. Include this header only from
// kernel sources, and call these helpers only from always_inline code: they pass vectors by
// value, whose calling convention differs between instruction sets (hence -Wpsabi off).
#pragma once

#include <cstdint>
#include <cstring>
#include <limits>

#pragma GCC diagnostic ignored "-Wpsabi"  // GCC and Clang both know this name

namespace transient::simd {

inline constexpr int kLanes = 8;
using Vd = double __attribute__((vector_size(kLanes * sizeof(double))));
using Vm = int64_t __attribute__((vector_size(kLanes * sizeof(int64_t))));  // a comparison

__attribute__((always_inline)) inline Vd Load(const double* p) {
  Vd v;
  std::memcpy(&v, p, sizeof(v));
  return v;
}
__attribute__((always_inline)) inline void Store(double* p, Vd v) { std::memcpy(p, &v, sizeof(v)); }
__attribute__((always_inline)) inline Vd Splat(double x) { return Vd{} + x; }
__attribute__((always_inline)) inline Vm True() { return Vm{} == Vm{}; }
// yes where mask is set, no elsewhere.
__attribute__((always_inline)) inline Vd Select(Vm mask, Vd yes, Vd no) {
  return reinterpret_cast<Vd>((mask & reinterpret_cast<Vm>(yes)) |
                              (~mask & reinterpret_cast<Vm>(no)));
}
__attribute__((always_inline)) inline Vd Abs(Vd x) {
  return reinterpret_cast<Vd>(reinterpret_cast<Vm>(x) & (Vm{} + 0x7fffffffffffffff));
}
// The square root of every lane (one vsqrtpd where the instruction set has it).
__attribute__((always_inline)) inline Vd Sqrt(Vd x) {
  Vd root;
  for (int i = 0; i < kLanes; ++i) root[i] = __builtin_sqrt(x[i]);
  return root;
}
// Finite lanes (not NaN, not infinite).
__attribute__((always_inline)) inline Vm Finite(Vd x) {
  return Abs(x) <= std::numeric_limits<double>::max();
}
__attribute__((always_inline)) inline bool Any(Vm mask) {
  int64_t any = 0;
  for (int i = 0; i < kLanes; ++i) any |= mask[i];
  return any != 0;
}
__attribute__((always_inline)) inline bool All(Vm mask) {
  int64_t all = -1;
  for (int i = 0; i < kLanes; ++i) all &= mask[i];
  return all != 0;
}

// The instruction sets a kernel is compiled for, best first.
enum class Level { kX86_64_V4, kX86_64_V3, kBaseline };

// The best level this CPU runs (x86-64-v4: AVX-512 F/BW/CD/DQ/VL; v3: AVX2, FMA, BMI1/2).
inline Level CpuLevel() {
  static const Level level = [] {
    __builtin_cpu_init();
    const bool v3 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
                    __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2");
    const bool v4 = v3 && __builtin_cpu_supports("avx512f") &&
                    __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512cd") &&
                    __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl");
    return v4 ? Level::kX86_64_V4 : v3 ? Level::kX86_64_V3 : Level::kBaseline;
  }();
  return level;
}

}  // namespace transient::simd

// Defines NAME(PARAMS) calling the always_inline BODY(ARGS) compiled for each Level, chosen
// at the first call by simd::CpuLevel(). Under the sanitizers (TRANSIENT_SIMD_BASELINE_ONLY,
// set by CMake) only the baseline: the same source, a third of the compile time; the release
// tests run the vector instruction sets.
#if defined(TRANSIENT_SIMD_BASELINE_ONLY)
#define TRANSIENT_SIMD_VARIANTS(NAME, BODY, PARAMS, ARGS) \
  void NAME PARAMS { BODY ARGS; }
#else
#define TRANSIENT_SIMD_VARIANTS(NAME, BODY, PARAMS, ARGS)                 \
  __attribute__((target("arch=x86-64-v4"))) void NAME##V4 PARAMS { BODY ARGS; } \
  __attribute__((target("arch=x86-64-v3"))) void NAME##V3 PARAMS { BODY ARGS; } \
  void NAME##Baseline PARAMS { BODY ARGS; }                                 \
  void NAME PARAMS {                                                        \
    switch (::transient::simd::CpuLevel()) {                                \
      case ::transient::simd::Level::kX86_64_V4:                            \
        return NAME##V4 ARGS;                                               \
      case ::transient::simd::Level::kX86_64_V3:                            \
        return NAME##V3 ARGS;                                               \
      case ::transient::simd::Level::kBaseline:                             \
        return NAME##Baseline ARGS;                                         \
    }                                                                       \
  }
#endif
