// The optimized cumulative (thesis §8.4.4, eq. 8.9): the partial fractions of
// MeseCumulative (cumulative.cc) found per pixel as there, their closed form then summed at
// eight or four phases at a time, one SIMD lane per phase (kernels_simd.h), with the logarithm
// and arctangent of each lane computed in the lanes (optimized_cumulative_lanes.inc) instead of
// glibc's log and atan per value, which were 40 % of the kernel's time at m = 3 (`perf`,
// BM_CumulativeSlices). Their error is within a few units in the last place of glibc's
// (tests/reconstruct/kernels_test.cc), far below the float slices' rounding.
#include <array>
#include <cstdint>
#include <numbers>
#include <span>

#include "kernels_internal.h"
#include "kernels_simd.h"
#include "transient/reconstruct/cumulative.h"

namespace transient::internal {
namespace {

#define TRANSIENT_LANE_CODE "optimized_cumulative_lanes.inc"
#include "simd_namespaces.inc"

}  // namespace

TRANSIENT_SIMD_VARIANTS(CumulativeLanes, CumulativeBody,
                        (const SolvedImage& solved, std::span<const double> phases,
                         std::span<const double> cosines, std::span<const double> sines,
                         int64_t begin, int64_t end, std::span<float> out),
                        (solved, phases, cosines, sines, begin, end, out))

TRANSIENT_SIMD_VARIANTS(LogAndArgLanes, LogAndArgBody,
                        (const double* x, const double* y, int64_t count, double* log, double* arg),
                        (x, y, count, log, arg))

}  // namespace transient::internal
