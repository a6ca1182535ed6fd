// Per-pixel-range loops shared by the reference kernels (which run them over the whole image
// on one thread) and the optimized ones (which run them over row blocks on many threads).
// Every function writes only the pixels in [begin, end) of outputs allocated by the caller.
#pragma once

#include <omp.h>

#include <algorithm>
#include <complex>
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

// MeseDenominatorSeries (mese.h) across `count` pixels, one SIMD lane each, from planes x_j
// (x_re + j * in_stride, x_im likewise; j = 0..m): a0 = sum_j |x_j|^2 and, for k = 1..m,
// kScale Re a_k and -kScale Im a_k with a_k = sum_j conj(x_{j+k}) x_j, into planes at
// re + (k - 1) * out_stride, im likewise. The optimized density takes kScale = 2 (its cosine
// series' alpha_k and beta_k), the range kernel 1, from p = conj(q) (then -Im a_k(p) =
// Im a_k(q)). Inlined into each kernel's instruction-set variants.
template <int kScale>
__attribute__((always_inline)) inline void DenominatorSeriesPlanes(
    const double* x_re, const double* x_im, int64_t in_stride, int m, int64_t count, double* a0,
    double* re, double* im, int64_t out_stride) {
#pragma omp simd
  for (int64_t l = 0; l < count; ++l) a0[l] = 0.0;
  for (int j = 0; j <= m; ++j) {
    const double* yr = x_re + j * in_stride;
    const double* yi = x_im + j * in_stride;
#pragma omp simd
    for (int64_t l = 0; l < count; ++l) a0[l] += yr[l] * yr[l] + yi[l] * yi[l];
  }
  for (int k = 1; k <= m; ++k) {
    double* sum_re = re + (k - 1) * out_stride;
    double* sum_im = im + (k - 1) * out_stride;
#pragma omp simd
    for (int64_t l = 0; l < count; ++l) sum_re[l] = sum_im[l] = 0.0;
    for (int j = 0; j + k <= m; ++j) {
      const double* xr = x_re + (j + k) * in_stride;
      const double* xi = x_im + (j + k) * in_stride;
      const double* yr = x_re + j * in_stride;
      const double* yi = x_im + j * in_stride;
#pragma omp simd
      for (int64_t l = 0; l < count; ++l) {
        if constexpr (kScale == 1) {
          sum_re[l] += xr[l] * yr[l] + xi[l] * yi[l];
          sum_im[l] += xi[l] * yr[l] - xr[l] * yi[l];
        } else {
          sum_re[l] += kScale * (xr[l] * yr[l] + xi[l] * yi[l]);
          sum_im[l] += kScale * (xi[l] * yr[l] - xr[l] * yi[l]);
        }
      }
    }
  }
}

// x^n for 0 <= n <= kMaxOrder by binary powering: at most 10 products (~10 ulp), where
// std::polar(1, n * angle) would cost a sine and cosine per harmonic. UnwrapPixel's, and the
// optimized unwrapping's where it must compute exactly the same values (its lanes mirror it).
inline std::complex<double> Power(std::complex<double> x, int n) {
  std::complex<double> result = 1.0;
  for (; n > 0; n >>= 1) {
    if (n & 1) result *= x;
    x *= x;
  }
  return result;
}

// a / b by Smith's algorithm (scaled by the larger part of b, so that no square overflows), in
// real arithmetic: std::complex's division calls __divdc3 (C's Annex G handling of infinities),
// which cost more than the arithmetic around it in the cumulative's Init and InverseLevinson.
inline std::complex<double> Divide(std::complex<double> a, std::complex<double> b) {
  if (std::abs(b.real()) >= std::abs(b.imag())) {
    const double r = b.imag() / b.real(), d = b.real() + b.imag() * r;
    return {(a.real() + a.imag() * r) / d, (a.imag() - a.real() * r) / d};
  }
  const double r = b.real() / b.imag(), d = b.imag() + b.real() * r;
  return {(a.real() * r + a.imag()) / d, (a.imag() * r - a.real()) / d};
}

// UnwrapImage's outputs (phase_unwrapping.h), sized for the image and filled with NaN and 0.
struct UnwrapOutputs {
  float* range_m;
  float* amplitude;
  float* confidence;
  uint8_t* flags;
};
// UnwrapImage's per-pixel loop for pixels [begin, end), eight or four at a time
// (optimized_unwrap.cc).
void UnwrapPixels(const MomentImage& moments, const UnwrapOptions& options, int64_t begin,
                  int64_t end, UnwrapOutputs out);

// Sizes `solved` for `moments`, reusing its buffers, with every flag 0; SolvePixels writes
// every value of its pixels (NaN for invalid ones), so nothing else is initialised here.
void PrepareSolved(const MomentImage& moments, SolvedImage* solved);
// Pisarenko output sized for `solved`, every value NaN.
PisarenkoImage AllocatePisarenko(const SolvedImage& solved);

// Validation, zeroth moment, biasing and Levinson. With `quick_bias_check`, a pixel whose C(c)
// passes Levinson's positive-definiteness test at c_0 (1 - eps) skips biasing's search for
// lambda_min: then lambda_min > eps c_0 already and biasing would change nothing.
void SolvePixels(const MomentImage& moments, const SolveOptions& options, bool quick_bias_check,
                 int64_t begin, int64_t end, SolvedImage* solved);
// The optimized solve of pixels [begin, end) for a measured c_0 (ZerothMoment::kMeasured): for
// orders up to 8 (under the sanitizers 1, 3, 4 and 8), eight or four pixels at a time in SIMD
// lanes (optimized_solve.cc), biasing included; the pixels whose biasing the lanes cannot vouch
// for, the last ones of the block and other orders by SolvePixels. Returns how many pixels that
// needed biasing's lambda_min the lanes decided.
int64_t SolveBlock(const MomentImage& moments, const SolveOptions& options, int64_t begin,
                   int64_t end, SolvedImage* solved);
// With a `grid`, each pixel tries PisarenkoByLevinson first and takes Pisarenko() where that
// declines; without, Pisarenko() alone (the reference).
void PisarenkoPixels(const SolvedImage& solved, int64_t begin, int64_t end, PisarenkoImage* result,
                     const PisarenkoSearchGrid* grid = nullptr);
// The optimized kernels' Pisarenko of pixels [begin, end): for orders up to 8 (under the
// sanitizers 1, 3, 4 and 8), eight or four pixels at a time in SIMD lanes (kernels_simd.h) by
// PisarenkoByLevinson's route (optimized_pisarenko.cc); the pixels the lanes cannot vouch for, the
// last ones of the block and other orders by PisarenkoPixels with `grid`. Returns how many pixels
// the lanes decided.
int64_t PisarenkoBlock(const SolvedImage& solved, const PisarenkoSearchGrid& grid, int64_t begin,
                       int64_t end, PisarenkoImage* result);
// By MeseCumulative::operator() at each phase (the reference).
void CumulativePixels(const SolvedImage& solved, std::span<const double> phases, int64_t begin,
                      int64_t end, std::span<float> out);
// The optimized kernel's (optimized_cumulative.cc): the closed form at kLanes phases a vector,
// given the phases' cosines and sines; the rest by MeseCumulative::Evaluate.
void CumulativeLanes(const SolvedImage& solved, std::span<const double> phases,
                     std::span<const double> cosines, std::span<const double> sines, int64_t begin,
                     int64_t end, std::span<float> out);
// The lanes' log x and atan(y / x) (x > 0) of `count` values, for the tests of their accuracy.
void LogAndArgLanes(const double* x, const double* y, int64_t count, double* log, double* arg);
void BoundPixels(const SolvedImage& solved, double r, std::span<const double> phases, int64_t begin,
                 int64_t end, std::span<float> lower, std::span<float> upper);

// MESE range of pixels [begin, end): per pixel, the grid by Horner and MeseFirstPeakPhase.
void MeseRangePixels(const SolvedImage& solved, const RangeOptions& options, int64_t begin,
                     int64_t end, std::span<float> range_m, std::span<uint8_t> flags);

}  // namespace transient::internal
