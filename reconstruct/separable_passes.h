// The rows of a separable filter with a symmetric kernel k[0..r], shared by the Gaussian filter
// of moment depth maps (moment_filter.cc) and the smoothing of moment images (smoothing.cc).
// Both run the passes row by row over a ring of 2r + 1 row-filtered rows, so the intermediate
// image stays in L1/L2. The hot loops are compiled for AVX2 and for plain x86-64, chosen at load
// time (target_clones, as in optimized_kernels.cc); with the radius a compile-time constant up
// to kMaxUnrolledRadius the sum over d unrolls into registers, one SIMD lane per x.
#ifndef TRANSIENT_RECONSTRUCT_SEPARABLE_PASSES_H_
#define TRANSIENT_RECONSTRUCT_SEPARABLE_PASSES_H_

namespace transient::internal {

// The largest radius with an unrolled kernel (sigma <= 5.33 px); wider ones take a generic loop
// with the same order of additions.
inline constexpr int kMaxUnrolledRadius = 16;

// out[x] = k[0] padded[x] + sum_{d = 1..r} k[d] (padded[x - d] + padded[x + d]), x = 0..width-1,
// where `padded` points at x = 0 of a row with r values beyond each end (the caller's edges:
// clamped, or zeros).
void RowPass(const float* kernel, int radius, const float* padded, int width, float* out);

// out[x] = k[0] rows[r][x] + sum_{d = 1..r} k[d] (rows[r - d][x] + rows[r + d][x]): rows[] are
// the 2r + 1 source rows around the output row (the caller's edges: clamped rows, or a row of
// zeros).
void ColumnPass(const float* kernel, int radius, const float* const* rows, int width, float* out);

}  // namespace transient::internal

#endif  // TRANSIENT_RECONSTRUCT_SEPARABLE_PASSES_H_
