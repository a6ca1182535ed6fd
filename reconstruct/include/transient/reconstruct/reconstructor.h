// Image-level reconstruction API: moment images in, per-pixel state and products out.
//
// Every function here loops over independent pixels and writes planar outputs; callers never
// see the per-pixel loop, so a faster implementation (SIMD, threads) can replace the body
// without changing them. Per-pixel math is double precision because this is the reference
// (oracle) that optimized kernels are tested against; float Levinson at m = 16 is ~1e-4
// relative off in density (tests/reconstruct/reconstructor_test.cc measures it).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "transient/reconstruct/biasing.h"
#include "transient/reconstruct/image.h"

namespace transient {

// How c_0 is obtained (thesis §8.3.3).
enum class ZerothMoment {
  kMeasured,  // plane 0 of the input holds c_0
  kEstimate,  // plane 0 is ignored; c_0 := -lambda_min(zero-diagonal C) / (1 - eps)
};

inline constexpr double kMinBiasEpsilon = 1e-6;

struct SolveOptions {
  double bias_epsilon = 4e-3;  // thesis §8.5: lambda_min >= 4e-3 * c_0; >= kMinBiasEpsilon
  BiasMode bias_mode = BiasMode::kRaiseZeroth;
  ZerothMoment zeroth = ZerothMoment::kMeasured;

  absl::Status Validate() const;
};

// Per-pixel reconstruction state of one frame: the moments after zeroth-moment estimation and
// biasing, and q = C^{-1}(c) e_0 (thesis alg. 8.1), from which every MESE product follows.
struct SolvedImage {
  ImageGeometry geometry;
  int order = 0;
  std::vector<double> c_real, c_imag;  // (m+1) planes; c_imag plane 0 is zero
  std::vector<double> q_real, q_imag;  // (m+1) planes; NaN for invalid pixels
  std::vector<uint8_t> flags;          // PixelFlag bits

  bool valid(int64_t pixel) const { return (flags[pixel] & kFlagInvalidInput) == 0; }
  double c0(int64_t pixel) const { return c_real[pixel]; }
  // Gathers the m+1 moments / coefficients of one pixel.
  void moments(int64_t pixel, std::span<Complex> c) const;
  void coefficients(int64_t pixel, std::span<Complex> q) const;
};

// Validates and biases every pixel and runs Levinson's algorithm. `moments` must pass
// MomentImage::Validate() and `options` SolveOptions::Validate() (asserted).
SolvedImage Solve(const MomentImage& moments, const SolveOptions& options);
// The same into `solved`, reusing its buffers: a stream of frames allocates (and the kernel
// first-touches) its per-pixel state once, not per frame.
void Solve(const MomentImage& moments, const SolveOptions& options, SolvedImage* solved);

// Pisarenko estimate of every pixel (thesis §8.4.1), from the biased moments.
struct PisarenkoImage {
  ImageGeometry geometry;
  int order = 0;
  std::vector<float> phase;    // m planes, radians in [0, 2*pi), sorted ascending; NaN padding
  std::vector<float> weight;   // m planes, same order as phase; NaN padding
  std::vector<float> uniform;  // 1 plane: strength of the uniform component (lambda_min)
};
PisarenkoImage EstimatePisarenko(const SolvedImage& solved);

// The phases 2*pi*n/bins, n = 0..bins-1.
std::vector<double> UniformPhases(int bins);

// MESE density D(phi) per radian (thesis eq. 8.3): out[n * pixels + p] = D_p(phases[n]).
void DensitySlices(const SolvedImage& solved, std::span<const double> phases, std::span<float> out);

// Cumulative MESE distribution F_D([0, phi]) (thesis eq. 8.9), same layout as DensitySlices.
// Every phase must lie in [0, 2*pi].
void CumulativeSlices(const SolvedImage& solved, std::span<const double> phases,
                      std::span<float> out);

// Sharp bounds of the Poisson-smoothed density for r in (0, 1) (thesis prop. 8.4), same layout.
void BoundSlices(const SolvedImage& solved, double r, std::span<const double> phases,
                 std::span<float> lower, std::span<float> upper);

struct RangeOptions {
  double base_frequency_hz = 23e6;
  // Relative to the pixel's highest density or, for a MESE peak that stands apart, the
  // brightest peak's light (MeseFirstPeakPhase); to the largest weight of a Pisarenko return.
  double threshold = 0.1;
  // Grid on which MESE peaks are searched before Newton refinement. 0 = automatic:
  // 16 (m+1) phases, 8x the Nyquist rate of the degree-m denominator, so that every minimum
  // of it shows on the grid unless another lies within 2*pi/(16 (m+1)).
  int search_bins = 0;

  absl::Status Validate() const;
  int SearchBins(int order) const { return search_bins > 0 ? search_bins : 16 * (order + 1); }
};

// Range of the first MESE return by MeseFirstPeakPhase's rule (thesis §8.4.3), metres; NaN and
// kFlagNoReturn in `flags` where there is none. `range_m` and `flags` have one entry per pixel.
void MeseRange(const SolvedImage& solved, const RangeOptions& options, std::span<float> range_m,
               std::span<uint8_t> flags);

// Range of the first Pisarenko return whose weight is above the threshold; as MeseRange.
// Pass the SolvedImage's flags: a pixel without a Pisarenko estimate that is not flagged
// invalid gets kFlagNoReturn.
void PisarenkoRange(const PisarenkoImage& pisarenko, const RangeOptions& options,
                    std::span<float> range_m, std::span<uint8_t> flags);

// Amplitude |c_1|: the modulus of the first harmonic, what AMCW cameras report as amplitude
// (sensor units); NaN for invalid pixels. `out` has one entry per pixel.
void Amplitude(const SolvedImage& solved, std::span<float> out);

// Direct/indirect separation (thesis §8.4.1): direct = weight of the first return above the
// threshold, indirect = sum of the other returns' weights (the uniform component is neither).
void SeparateDirectIndirect(const PisarenkoImage& pisarenko, double threshold,
                            std::span<float> direct, std::span<float> indirect);

}  // namespace transient
