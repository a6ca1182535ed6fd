// SIMD lanes of doubles in GCC's generic vectors (also understood by Clang), for the optimized
// kernels' per-pixel work that the auto-vectorizer does not take on (Newton steps with per-lane
// masks, Levinson's recursion), one pixel or candidate a lane. A kernel is compiled once per
// instruction set (TRANSIENT_SIMD_VARIANTS below): AVX-512 with eight lanes (one register a
// vector), AVX2 with four (one register), the baseline with eight (four SSE2 registers). The
// lane code is written once, in a `*_lanes.inc` file that the kernel's source compiles into a
// namespace per lane count, `lanes8` and `lanes4` (simd_namespaces.inc), each after `kLanes` and
// simd_lanes.inc (the vector types and their helpers). On the AVX2 VM eight lanes as two AVX2
// registers ran 1.4-4.2x slower than four as one (docs/speed.md): the kernels keep more vectors
// live than AVX2's sixteen registers hold, and spilled them. The baseline keeps eight: with four,
// GCC took 265 s to compile its Pisarenko lanes against 70 s (one run each), and it runs only on
// CPUs without AVX2. Not with target_clones: GCC 12 lowers a clone's generic vector comparisons for
// the baseline instruction set, one scalar comparison per lane. Include the lane files only from
// kernel sources, and call their helpers only from always_inline code: they pass vectors by
// value, whose calling convention differs between instruction sets (hence -Wpsabi off there).
#pragma once

#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

namespace transient::simd {

// The most lanes of any instruction set: scratch arrays shared by every lane count are padded
// by this much.
inline constexpr int kMaxLanes = 8;

// The instruction sets a kernel is compiled for, best first.
enum class Level { kX86_64_V4, kX86_64_V3, kBaseline };

inline const char* LevelName(Level level) {
  switch (level) {
    case Level::kX86_64_V4:
      return "x86-64-v4";
    case Level::kX86_64_V3:
      return "x86-64-v3";
    case Level::kBaseline:
      return "baseline";
  }
  return "?";
}

// The best level this CPU runs (x86-64-v4: AVX-512 F/BW/CD/DQ/VL; v3: AVX2, FMA, BMI1/2).
inline Level DetectedLevel() {
  __builtin_cpu_init();
  const bool v3 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
                  __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2");
  const bool v4 = v3 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                  __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512dq") &&
                  __builtin_cpu_supports("avx512vl");
  return v4 ? Level::kX86_64_V4 : v3 ? Level::kX86_64_V3 : Level::kBaseline;
}

// The level to run on a CPU that runs `cpu` at best, given the environment variable
// TRANSIENT_SIMD (`cap`, null when unset): one of the level names caps it, so that the tests run
// the lower clones too (tests/reconstruct/CMakeLists.txt); a level above the CPU's, or any other
// value, leaves the CPU's and says why in *message (else left empty).
inline Level CappedLevel(const char* cap, Level cpu, std::string* message) {
  message->clear();
  if (cap == nullptr) return cpu;
  for (Level level : {Level::kX86_64_V4, Level::kX86_64_V3, Level::kBaseline}) {
    if (std::string_view(cap) != LevelName(level)) continue;
    if (level >= cpu) return level;
    *message = std::string("TRANSIENT_SIMD=") + cap + ": this CPU runs " + LevelName(cpu) +
               " at best; the vector kernels run " + LevelName(cpu);
    return cpu;
  }
  *message = std::string("TRANSIENT_SIMD=") + cap +
             ": expected x86-64-v4, x86-64-v3 or baseline; the vector kernels run " +
             LevelName(cpu);
  return cpu;
}

// The level the vector kernels run: this CPU's best, or lower if TRANSIENT_SIMD says so (a
// value it cannot follow is reported on stderr, once).
inline Level CpuLevel() {
  static const Level level = [] {
    std::string message;
    const Level capped = CappedLevel(std::getenv("TRANSIENT_SIMD"), DetectedLevel(), &message);
    if (!message.empty()) std::fprintf(stderr, "transient: %s\n", message.c_str());
    return capped;
  }();
  return level;
}

}  // namespace transient::simd

// Unrolls the loop after it completely in the release builds: over an order's terms (at most
// kMaxOrder) GCC at -O2 (the range kernel's level) kept the loop, its counter converted to a
// double each time round; over the range kernel's groups of minima (RefineSlots) it kept their
// state in memory. Not under the sanitizers, where Clang's compile time counts and speed does
// not (the range kernel 22.7 -> 43 s there with it).
#if defined(TRANSIENT_SIMD_BASELINE_ONLY)
#define TRANSIENT_UNROLL_ORDER
#else
#define TRANSIENT_UNROLL_ORDER _Pragma("GCC unroll 16")
#endif

// Defines NAME(PARAMS) calling the always_inline BODY(ARGS) compiled for each Level, chosen
// at the first call by simd::CpuLevel(): x86-64-v4 and the baseline with lanes8::BODY,
// x86-64-v3 with lanes4::BODY. Under the sanitizers (TRANSIENT_SIMD_BASELINE_ONLY, set by CMake)
// only the baseline, with lanes8::BODY: a third of the compile time, and the sanitizer tests run
// the eight-lane code of AVX-512 machines while the release tests run the host's.
#if defined(TRANSIENT_SIMD_BASELINE_ONLY)
#define TRANSIENT_SIMD_VARIANTS(NAME, BODY, PARAMS, ARGS) \
  void NAME PARAMS { lanes8::BODY ARGS; }
#else
#define TRANSIENT_SIMD_VARIANTS(NAME, BODY, PARAMS, ARGS)                               \
  __attribute__((target("arch=x86-64-v4"))) void NAME##V4 PARAMS { lanes8::BODY ARGS; } \
  __attribute__((target("arch=x86-64-v3"))) void NAME##V3 PARAMS { lanes4::BODY ARGS; } \
  void NAME##Baseline PARAMS { lanes8::BODY ARGS; }                                     \
  void NAME PARAMS {                                                                    \
    switch (::transient::simd::CpuLevel()) {                                            \
      case ::transient::simd::Level::kX86_64_V4:                                        \
        return NAME##V4 ARGS;                                                           \
      case ::transient::simd::Level::kX86_64_V3:                                        \
        return NAME##V3 ARGS;                                                           \
      case ::transient::simd::Level::kBaseline:                                         \
        return NAME##Baseline ARGS;                                                     \
    }                                                                                   \
  }
#endif
