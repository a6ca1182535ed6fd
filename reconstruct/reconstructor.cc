// Image-level reconstruction: options, the per-pixel state, and the run-time choice between
// the reference and the optimized kernels (kernels.h).
#include "transient/reconstruct/reconstructor.h"

#include <omp.h>

#include <cassert>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "transient/reconstruct/kernels.h"

namespace transient {

absl::Status SolveOptions::Validate() const {
  // Below ~1e-6 the biased Toeplitz matrix is too close to singular for double precision:
  // at 1e-10 biasing itself cannot reach positive definiteness.
  if (!(bias_epsilon >= kMinBiasEpsilon && bias_epsilon < 1.0)) {
    return absl::InvalidArgumentError(absl::StrCat("bias_epsilon = ", bias_epsilon,
                                                   ". Violated constraint: ", kMinBiasEpsilon,
                                                   " <= bias_epsilon < 1"));
  }
  return absl::OkStatus();
}

absl::Status RangeOptions::Validate() const {
  if (!(base_frequency_hz > 0.0) || !std::isfinite(base_frequency_hz)) {
    return absl::InvalidArgumentError(absl::StrCat("base_frequency_hz = ", base_frequency_hz,
                                                   ". Violated constraint: finite and > 0"));
  }
  if (!(threshold >= 0.0 && threshold <= 1.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("threshold = ", threshold, ". Violated constraint: 0 <= threshold <= 1"));
  }
  if (search_bins != 0 && search_bins < 3) {
    return absl::InvalidArgumentError(absl::StrCat(
        "search_bins = ", search_bins, ". Violated constraint: search_bins == 0 or >= 3"));
  }
  return absl::OkStatus();
}

void SolvedImage::moments(int64_t pixel, std::span<Complex> c) const {
  const int64_t pixels = geometry.pixel_count();
  for (int j = 0; j <= order; ++j) c[j] = {c_real[j * pixels + pixel], c_imag[j * pixels + pixel]};
}

void SolvedImage::coefficients(int64_t pixel, std::span<Complex> q) const {
  const int64_t pixels = geometry.pixel_count();
  for (int j = 0; j <= order; ++j) q[j] = {q_real[j * pixels + pixel], q_imag[j * pixels + pixel]};
}

std::vector<double> UniformPhases(int bins) {
  assert(bins > 0);
  std::vector<double> phases(bins);
  for (int n = 0; n < bins; ++n) phases[n] = kTwoPi * n / bins;
  return phases;
}

namespace {

KernelOptions& CurrentKernelOptions() {
  static KernelOptions options;
  return options;
}

bool UseOptimized() { return CurrentKernelOptions().kind == KernelKind::kOptimized; }

}  // namespace

void SetKernelOptions(const KernelOptions& options) { CurrentKernelOptions() = options; }
KernelOptions GetKernelOptions() { return CurrentKernelOptions(); }

int KernelThreads() {
  const int requested = GetKernelOptions().threads;
  return requested > 0 ? requested : omp_get_max_threads();
}

SolvedImage Solve(const MomentImage& moments, const SolveOptions& options) {
  SolvedImage solved;
  Solve(moments, options, &solved);
  return solved;
}

void Solve(const MomentImage& moments, const SolveOptions& options, SolvedImage* solved) {
  UseOptimized() ? optimized::Solve(moments, options, solved)
                 : reference::Solve(moments, options, solved);
}

PisarenkoImage EstimatePisarenko(const SolvedImage& solved) {
  return UseOptimized() ? optimized::EstimatePisarenko(solved)
                        : reference::EstimatePisarenko(solved);
}

void DensitySlices(const SolvedImage& solved, std::span<const double> phases,
                   std::span<float> out) {
  UseOptimized() ? optimized::DensitySlices(solved, phases, out)
                 : reference::DensitySlices(solved, phases, out);
}

void CumulativeSlices(const SolvedImage& solved, std::span<const double> phases,
                      std::span<float> out) {
  UseOptimized() ? optimized::CumulativeSlices(solved, phases, out)
                 : reference::CumulativeSlices(solved, phases, out);
}

void BoundSlices(const SolvedImage& solved, double r, std::span<const double> phases,
                 std::span<float> lower, std::span<float> upper) {
  UseOptimized() ? optimized::BoundSlices(solved, r, phases, lower, upper)
                 : reference::BoundSlices(solved, r, phases, lower, upper);
}

void MeseRange(const SolvedImage& solved, const RangeOptions& options, std::span<float> range_m,
               std::span<uint8_t> flags) {
  UseOptimized() ? optimized::MeseRange(solved, options, range_m, flags)
                 : reference::MeseRange(solved, options, range_m, flags);
}

void PisarenkoRange(const PisarenkoImage& pisarenko, const RangeOptions& options,
                    std::span<float> range_m, std::span<uint8_t> flags) {
  // Per pixel this is a scan of at most m weights: memory-bound, no optimized variant.
  reference::PisarenkoRange(pisarenko, options, range_m, flags);
}

void Amplitude(const SolvedImage& solved, std::span<float> out) {
  // One complex modulus per pixel, a single implementation. The square root of the squares'
  // sum in double, not std::hypot: the moments come from float planes (MomentImage), so their
  // squares stay far inside double's range, which hypot guards against at 16 ns a pixel
  // (4.9 ms of a 640 x 480 frame, tests/bench's BM_VgaPipeline, stage 2).
  const int64_t pixels = solved.geometry.pixel_count();
  assert(out.size() == static_cast<size_t>(pixels));
  const double* re = solved.c_real.data() + pixels;
  const double* im = solved.c_imag.data() + pixels;
  for (int64_t p = 0; p < pixels; ++p) {
    out[p] = solved.valid(p) ? static_cast<float>(std::sqrt(re[p] * re[p] + im[p] * im[p]))
                             : std::numeric_limits<float>::quiet_NaN();
  }
}

void SeparateDirectIndirect(const PisarenkoImage& pisarenko, double threshold,
                            std::span<float> direct, std::span<float> indirect) {
  reference::SeparateDirectIndirect(pisarenko, threshold, direct, indirect);
}

}  // namespace transient
