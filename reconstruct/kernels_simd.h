// Eight doubles at a time in GCC's generic vectors (also understood by Clang), for the
// optimized kernels' per-pixel work that the auto-vectorizer does not take on (Newton steps
// with per-lane masks, Levinson's recursion). Every target_clones clone lowers them to its own
// instructions: one AVX-512 register, two AVX2 ones, four SSE2 ones. Include this header only
// from kernel sources, and call these helpers only from always_inline code: they pass vectors
// by value, whose calling convention differs between instruction sets (hence -Wpsabi off).
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
// Finite lanes (not NaN, not infinite).
__attribute__((always_inline)) inline Vm Finite(Vd x) {
  return Abs(x) <= std::numeric_limits<double>::max();
}
__attribute__((always_inline)) inline bool Any(Vm mask) {
  int64_t any = 0;
  for (int i = 0; i < kLanes; ++i) any |= mask[i];
  return any != 0;
}

}  // namespace transient::simd
