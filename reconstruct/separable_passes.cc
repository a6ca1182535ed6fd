// The rows of separable filters (separable_passes.h).
#include "separable_passes.h"

namespace transient::internal {
namespace {

// One row of the horizontal pass: out[x] = sum_{|d| <= r} k[|d|] padded[x + d], where `padded`
// points at x = 0 of a row with r edge values on each side. With the radius a
// compile-time constant the sum over d unrolls into registers, one SIMD lane per x.
template <int kRadius>
inline void RowPassFixed(const float* __restrict kernel, const float* __restrict padded, int width,
                         float* __restrict out) {
#pragma omp simd
  for (int x = 0; x < width; ++x) {
    float sum = kernel[0] * padded[x];
    for (int d = 1; d <= kRadius; ++d) sum += kernel[d] * (padded[x - d] + padded[x + d]);
    out[x] = sum;
  }
}

// One row of the vertical pass: out[x] = sum_{|d| <= r} k[|d|] rows[r + d][x], where rows[] are
// the 2r + 1 source rows around the output row.
template <int kRadius>
inline void ColumnPassFixed(const float* __restrict kernel, const float* const* rows, int width,
                            float* __restrict out) {
  const float* source[2 * kRadius + 1];
  for (int i = 0; i <= 2 * kRadius; ++i) source[i] = rows[i];
#pragma omp simd
  for (int x = 0; x < width; ++x) {
    float sum = kernel[0] * source[kRadius][x];
    for (int d = 1; d <= kRadius; ++d) {
      sum += kernel[d] * (source[kRadius - d][x] + source[kRadius + d][x]);
    }
    out[x] = sum;
  }
}

// Any radius: the same sums as shifted rows (d outer, x inner, the row staying in L1), which
// vectorize without unrolling. Same order of additions as the fixed kernels.
void RowPassGeneric(const float* __restrict kernel, int radius, const float* __restrict padded,
                    int width, float* __restrict out) {
  for (int x = 0; x < width; ++x) out[x] = kernel[0] * padded[x];
  for (int d = 1; d <= radius; ++d) {
    const float k = kernel[d];
    for (int x = 0; x < width; ++x) out[x] += k * (padded[x - d] + padded[x + d]);
  }
}

void ColumnPassGeneric(const float* __restrict kernel, int radius, const float* const* rows,
                       int width, float* __restrict out) {
  const float* center = rows[radius];
  for (int x = 0; x < width; ++x) out[x] = kernel[0] * center[x];
  for (int d = 1; d <= radius; ++d) {
    const float k = kernel[d];
    const float* __restrict up = rows[radius - d];
    const float* __restrict down = rows[radius + d];
    for (int x = 0; x < width; ++x) out[x] += k * (up[x] + down[x]);
  }
}

#define TRANSIENT_RADIUS_CASES(CASE)                                                          \
  CASE(1)                                                                                     \
  CASE(2)                                                                                     \
  CASE(3) CASE(4) CASE(5) CASE(6) CASE(7) CASE(8) CASE(9) CASE(10) CASE(11) CASE(12) CASE(13) \
      CASE(14) CASE(15) CASE(16)

}  // namespace

__attribute__((target_clones("arch=x86-64-v3", "default"))) void RowPass(const float* kernel,
                                                                         int radius,
                                                                         const float* padded,
                                                                         int width, float* out) {
  switch (radius) {
#define TRANSIENT_ROW_CASE(R) \
  case R:                     \
    return RowPassFixed<R>(kernel, padded, width, out);
    TRANSIENT_RADIUS_CASES(TRANSIENT_ROW_CASE)
#undef TRANSIENT_ROW_CASE
    default:
      return RowPassGeneric(kernel, radius, padded, width, out);
  }
}

__attribute__((target_clones("arch=x86-64-v3", "default"))) void ColumnPass(
    const float* kernel, int radius, const float* const* rows, int width, float* out) {
  switch (radius) {
#define TRANSIENT_COLUMN_CASE(R) \
  case R:                        \
    return ColumnPassFixed<R>(kernel, rows, width, out);
    TRANSIENT_RADIUS_CASES(TRANSIENT_COLUMN_CASE)
#undef TRANSIENT_COLUMN_CASE
    default:
      return ColumnPassGeneric(kernel, radius, rows, width, out);
  }
}
#undef TRANSIENT_RADIUS_CASES
static_assert(kMaxUnrolledRadius == 16, "TRANSIENT_RADIUS_CASES lists radii 1..16");

}  // namespace transient::internal
