// Per-pixel-range loops shared by the reference kernels (which run them over the whole image
// on one thread) and the optimized ones (which run them over row blocks on many threads).
// Every function writes only the pixels in [begin, end) of outputs allocated by the caller.
#pragma once

#include <cstdint>
#include <span>

#include "transient/reconstruct/reconstructor.h"

namespace transient::internal {

// Sizes `solved` for `moments`, reusing its buffers, with every flag 0; SolvePixels writes
// every value of its pixels (NaN for invalid ones), so nothing else is initialised here.
void PrepareSolved(const MomentImage& moments, SolvedImage* solved);
// Pisarenko output sized for `solved`, every value NaN.
PisarenkoImage AllocatePisarenko(const SolvedImage& solved);

// Validation, zeroth moment, biasing and Levinson. With `quick_bias_check`, a pixel whose C(c)
// passes Levinson's positive-definiteness test at c_0 (1 - eps) skips the dense eigen-solve:
// then lambda_min > eps c_0 already and biasing would change nothing.
void SolvePixels(const MomentImage& moments, const SolveOptions& options, bool quick_bias_check,
                 int64_t begin, int64_t end, SolvedImage* solved);
void PisarenkoPixels(const SolvedImage& solved, int64_t begin, int64_t end, PisarenkoImage* result);
void CumulativePixels(const SolvedImage& solved, std::span<const double> phases, int64_t begin,
                      int64_t end, std::span<float> out);
void BoundPixels(const SolvedImage& solved, double r, std::span<const double> phases, int64_t begin,
                 int64_t end, std::span<float> lower, std::span<float> upper);

}  // namespace transient::internal
