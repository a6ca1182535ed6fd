// Per-pixel-range loops shared by the reference kernels (which run them over the whole image
// on one thread) and the optimized ones (which run them over row blocks on many threads).
// Every function writes only the pixels in [begin, end) of outputs allocated by the caller.
#pragma once

#include <omp.h>

#include <algorithm>
#include <cstdint>
#include <span>

#include "transient/reconstruct/kernels.h"
#include "transient/reconstruct/phase_unwrapping.h"
#include "transient/reconstruct/pisarenko.h"
#include "transient/reconstruct/reconstructor.h"

namespace transient::internal {

// Pixels per work item of the optimized kernels: the series coefficients of a block (2m+2
// doubles per pixel) stay in L1/L2 while every phase sweeps over them.
inline constexpr int64_t kBlockPixels = 256;

// Runs body(begin, end) over [0, count) in blocks of `block` pixels on KernelThreads() threads.
template <typename Body>
void ParallelBlocks(int64_t count, const Body& body, int64_t block = kBlockPixels) {
  const int64_t blocks = (count + block - 1) / block;
#pragma omp parallel for num_threads(KernelThreads()) schedule(dynamic, 4)
  for (int64_t b = 0; b < blocks; ++b) {
    body(b * block, std::min(count, (b + 1) * block));
  }
}

// UnwrapImage's outputs (phase_unwrapping.h), sized for the image and filled with NaN and 0.
struct UnwrapOutputs {
  float* range_m;
  float* amplitude;
  float* confidence;
  uint8_t* flags;
};
// UnwrapImage's per-pixel loop for pixels [begin, end), eight at a time (optimized_unwrap.cc).
void UnwrapPixels(const MomentImage& moments, const UnwrapOptions& options, int64_t begin,
                  int64_t end, UnwrapOutputs out);

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
// With a `grid`, each pixel tries PisarenkoByLevinson first and takes Pisarenko() where that
// declines; without, Pisarenko() alone (the reference).
void PisarenkoPixels(const SolvedImage& solved, int64_t begin, int64_t end, PisarenkoImage* result,
                     const PisarenkoSearchGrid* grid = nullptr);
// With the phases' cosines and sines, by MeseCumulative::Evaluate (the optimized kernels);
// without, by MeseCumulative::operator() at each phase (the reference).
void CumulativePixels(const SolvedImage& solved, std::span<const double> phases, int64_t begin,
                      int64_t end, std::span<float> out, std::span<const double> cosines = {},
                      std::span<const double> sines = {});
void BoundPixels(const SolvedImage& solved, double r, std::span<const double> phases, int64_t begin,
                 int64_t end, std::span<float> lower, std::span<float> upper);

// MESE range of pixels [begin, end): per pixel, the grid by Horner and MeseFirstPeakPhase.
void MeseRangePixels(const SolvedImage& solved, const RangeOptions& options, int64_t begin,
                     int64_t end, std::span<float> range_m, std::span<uint8_t> flags);

}  // namespace transient::internal
