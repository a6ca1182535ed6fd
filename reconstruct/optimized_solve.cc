// The optimized solve: validation, biasing (thesis §8.3.3) and Levinson's algorithm (thesis
// alg. 8.1) for eight or four pixels at a time (kernels_simd.h), one SIMD lane per pixel, with the
// results of the reference's per-pixel loop (reference_kernels.cc, biasing.cc, levinson.cc) bit
// for bit:
// - every lane runs the same IEEE operations in the same order as the scalar code on
//   std::complex (a complex product is (ac - bd, ad + bc)), and this file is compiled without
//   contraction into fused multiply-adds (-ffp-contract=off, reconstruct/CMakeLists.txt), which
//   the reference, built for baseline x86-64, never uses either;
// - Levinson's positive-definiteness test at c_0 (1 - eps) proves lambda_min > eps c_0 for
//   pixels that then need no biasing; for the others (91 % of a calibrated camera's VGA frame,
//   docs/speed.md) biasing's lambda_min comes from ToeplitzLambdaMin's steps in lanes
//   (levinson_lanes.inc), and a pixel whose lanes cannot vouch for it, like every pixel when c_0
//   is estimated, takes the reference's per-pixel path (biasing.cc: the same steps, then
//   Gershgorin's start or a dense eigen-solve).
#include <cassert>
#include <cstdint>
#include <cstring>
#include <limits>
#include <utility>

#include "kernels_internal.h"
#include "kernels_simd.h"
#include "transient/reconstruct/biasing.h"
#include "transient/reconstruct/kernels.h"
#include "transient/reconstruct/levinson.h"

namespace transient::optimized {
namespace {

// The lane code for each lane count (kernels_simd.h).
#define TRANSIENT_LANE_CODE "optimized_solve_lanes.inc"
#include "simd_namespaces.inc"

TRANSIENT_SIMD_VARIANTS(SolveBlockLanes, SolveBlockAnyOrder,
                        (const MomentImage& moments, const SolveOptions& options, int64_t begin,
                         int64_t end, SolvedImage* solved, int64_t* decided),
                        (moments, options, begin, end, solved, decided))

}  // namespace

void Solve(const MomentImage& moments, const SolveOptions& options, SolvedImage* solved) {
  assert(moments.Validate().ok() && options.Validate().ok());
  internal::PrepareSolved(moments, solved);
  const bool lanes = options.zeroth == ZerothMoment::kMeasured;
  internal::ParallelBlocks(moments.geometry.pixel_count(), [&](int64_t begin, int64_t end) {
    if (lanes) {
      (void)internal::SolveBlock(moments, options, begin, end, solved);
    } else {
      internal::SolvePixels(moments, options, /*quick_bias_check=*/true, begin, end, solved);
    }
  });
}

}  // namespace transient::optimized

namespace transient::internal {

int64_t SolveBlock(const MomentImage& moments, const SolveOptions& options, int64_t begin,
                   int64_t end, SolvedImage* solved) {
  int64_t decided = 0;
  optimized::SolveBlockLanes(moments, options, begin, end, solved, &decided);
  return decided;
}

}  // namespace transient::internal
