// The optimized phase unwrapping (phase_unwrapping.h): UnwrapPixel's arithmetic for eight
// or four pixels at once, one SIMD lane per pixel (kernels_simd.h). Every lane does the IEEE
// operations of UnwrapPixel in the same order (this file is compiled without fused multiply-adds,
// as optimized_solve.cc), and the transcendental functions (the highest harmonic's argument, the
// first candidate's e^{-i theta_0}, large Newton rotations) are the same library calls per
// lane, so the results equal UnwrapPixel's bit for bit (tests/reconstruct/phase_unwrapping_test).
// The J candidates are scored for all lanes together (J is the same for every pixel), and the
// Newton steps run while any lane still rises, masked per lane.
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <cstring>
#include <limits>
#include <utility>

#include "kernels_internal.h"
#include "kernels_simd.h"
#include "transient/reconstruct/moments.h"
#include "transient/reconstruct/phase_unwrapping.h"

namespace transient::internal {
namespace {

// The lane code for each lane count (kernels_simd.h).
#define TRANSIENT_LANE_CODE "optimized_unwrap_lanes.inc"
#include "simd_namespaces.inc"

}  // namespace

TRANSIENT_SIMD_VARIANTS(UnwrapPixels, UnwrapBody,
                        (const MomentImage& moments, const UnwrapOptions& options, int64_t begin,
                         int64_t end, UnwrapOutputs out),
                        (moments, options, begin, end, out))

}  // namespace transient::internal
