// The optimized solve: validation, the biasing check and Levinson's algorithm (thesis alg. 8.1)
// for eight pixels at a time, one SIMD lane per pixel, with the results of the reference's
// per-pixel loop (reference_kernels.cc, levinson.cc) bit for bit:
// - every lane runs the same IEEE operations in the same order as Levinson() on std::complex
//   (a complex product is (ac - bd, ad + bc)), and this file is compiled without contraction
//   into fused multiply-adds (-ffp-contract=off, reconstruct/CMakeLists.txt), which the
//   reference, built for baseline x86-64, never uses either;
// - Levinson's positive-definiteness test at c_0 (1 - eps) proves lambda_min > eps c_0 for
//   most pixels, which then need no biasing; the others (and every pixel when c_0 is
//   estimated) take the reference's per-pixel path, which runs the dense eigen-solve.
#include <cassert>
#include <cstdint>
#include <cstring>

#include "kernels_internal.h"
#include "kernels_simd.h"
#include "levinson_lanes.h"
#include "transient/reconstruct/kernels.h"

namespace transient::optimized {
namespace {

using simd::Finite;
using simd::kLanes;
using simd::Select;
using simd::Splat;
using simd::Store;
using simd::True;
using simd::Vd;
using simd::Vm;

// Eight floats from p, widened to double.
__attribute__((always_inline)) inline Vd LoadFloats(const float* p) {
  using Vf = float __attribute__((vector_size(kLanes * sizeof(float))));
  Vf f;
  std::memcpy(&f, p, sizeof(f));
  return __builtin_convertvector(f, Vd);
}

// Pixels [p, p + kLanes) of a kMeasured solve.
template <int M>
__attribute__((always_inline)) inline void SolveLanes(const MomentImage& moments,
                                                      const SolveOptions& options, int64_t p,
                                                      SolvedImage* solved) {
  const int64_t pixels = moments.geometry.pixel_count();
  Vd cr[M + 1], ci[M + 1];
  for (int j = 0; j <= M; ++j) {
    cr[j] = LoadFloats(moments.real_plane(j) + p);
    ci[j] = j == 0 ? Splat(0.0) : LoadFloats(moments.imag_plane(j) + p);
  }
  Vm valid = True();
  if (moments.valid.size() != 0) {  // not empty(): Clang 15 would not emit its iterator here
    for (int i = 0; i < kLanes; ++i) valid[i] = moments.valid[p + i] != 0 ? -1 : 0;
  }
  for (int j = 0; j <= M; ++j) valid &= Finite(cr[j]) & Finite(ci[j]);
  valid &= cr[0] > Splat(0.0);
  // The check of reference_kernels.cc's ClearlyAboveBound: Levinson at c_0 (1 - eps).
  Vd shifted[M + 1], qr[M + 1], qi[M + 1];
  shifted[0] = cr[0] * (1.0 - options.bias_epsilon);
  for (int j = 1; j <= M; ++j) shifted[j] = cr[j];
  const Vm clear = simd::LevinsonLanes<M>(shifted[0], shifted, ci, qr, qi);
  const Vm solved_ok = simd::LevinsonLanes<M>(cr[0], cr, ci, qr, qi);
  // Whole vectors into the planes (at VGA they are far beyond the caches: one store a line,
  // not eight), NaN where invalid; the lanes that need biasing are then overwritten below.
  const Vm ok = valid & solved_ok;
  const Vd nan = Splat(kNaN);
  for (int j = 0; j <= M; ++j) {
    const int64_t at = j * pixels + p;
    Store(solved->c_real.data() + at, Select(ok, cr[j], nan));
    Store(solved->c_imag.data() + at, Select(ok, ci[j], nan));
    Store(solved->q_real.data() + at, Select(ok, qr[j], nan));
    Store(solved->q_imag.data() + at, Select(ok, qi[j], nan));
  }
  for (int i = 0; i < kLanes; ++i) {
    const int64_t pixel = p + i;
    if (valid[i] != 0 && clear[i] == 0) {
      // Needs the eigen-solve of biasing (or is invalid after it): the per-pixel path.
      internal::SolvePixels(moments, options, /*quick_bias_check=*/false, pixel, pixel + 1,
                            solved);
      continue;
    }
    if (ok[i] == 0) solved->flags[pixel] |= kFlagInvalidInput;
  }
}

__attribute__((always_inline)) inline void SolveBlockAnyOrder(const MomentImage& moments,
                                                              const SolveOptions& options,
                                                              int64_t begin, int64_t end,
                                                              SolvedImage* solved) {
  int64_t p = begin;
  // Orders up to 8 in lanes (each order compiled costs compile time, growing as m^2); above,
  // the per-pixel path.
  for (; moments.order <= 8 && p + kLanes <= end; p += kLanes) {
    switch (moments.order) {
#define TRANSIENT_SOLVE_CASE(M)                           \
  case M:                                                 \
    SolveLanes<M>(moments, options, p, solved);           \
    break;
      TRANSIENT_SOLVE_CASE(1)
      TRANSIENT_SOLVE_CASE(2)
      TRANSIENT_SOLVE_CASE(3)
      TRANSIENT_SOLVE_CASE(4)
      TRANSIENT_SOLVE_CASE(5)
      TRANSIENT_SOLVE_CASE(6)
      TRANSIENT_SOLVE_CASE(7)
      TRANSIENT_SOLVE_CASE(8)
#undef TRANSIENT_SOLVE_CASE
    }
  }
  // The last pixels of the block, fewer than a vector.
  internal::SolvePixels(moments, options, /*quick_bias_check=*/true, p, end, solved);
}

TRANSIENT_SIMD_VARIANTS(SolveBlock, SolveBlockAnyOrder,
                        (const MomentImage& moments, const SolveOptions& options, int64_t begin,
                         int64_t end, SolvedImage* solved),
                        (moments, options, begin, end, solved))

}  // namespace

void Solve(const MomentImage& moments, const SolveOptions& options, SolvedImage* solved) {
  assert(moments.Validate().ok() && options.Validate().ok());
  internal::PrepareSolved(moments, solved);
  const bool lanes = options.zeroth == ZerothMoment::kMeasured;
  internal::ParallelBlocks(moments.geometry.pixel_count(), [&](int64_t begin, int64_t end) {
    if (lanes) {
      SolveBlock(moments, options, begin, end, solved);
    } else {
      internal::SolvePixels(moments, options, /*quick_bias_check=*/true, begin, end, solved);
    }
  });
}

}  // namespace transient::optimized
