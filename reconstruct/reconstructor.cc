// Image-level reconstruction: the per-pixel reference loops over the kernels of this folder.
#include "transient/reconstruct/reconstructor.h"

#include <array>
#include <cassert>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "transient/reconstruct/bounds.h"
#include "transient/reconstruct/cumulative.h"
#include "transient/reconstruct/levinson.h"
#include "transient/reconstruct/mese.h"
#include "transient/reconstruct/pisarenko.h"
#include "transient/reconstruct/range.h"

namespace transient {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();

bool AllFinite(std::span<const Complex> c) {
  for (const Complex& v : c) {
    if (!std::isfinite(v.real()) || !std::isfinite(v.imag())) return false;
  }
  return true;
}

}  // namespace

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
  if (search_bins < 3) {
    return absl::InvalidArgumentError(
        absl::StrCat("search_bins = ", search_bins, ". Violated constraint: search_bins >= 3"));
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

SolvedImage Solve(const MomentImage& moments, const SolveOptions& options) {
  assert(moments.Validate().ok() && options.Validate().ok());
  const int64_t pixels = moments.geometry.pixel_count();
  const int size = moments.order + 1;
  SolvedImage solved;
  solved.geometry = moments.geometry;
  solved.order = moments.order;
  solved.c_real.assign(size * pixels, kNaN);
  solved.c_imag.assign(size * pixels, kNaN);
  solved.q_real.assign(size * pixels, kNaN);
  solved.q_imag.assign(size * pixels, kNaN);
  solved.flags.assign(pixels, 0);

  std::array<Complex, kMaxMoments> c_storage, q_storage;
  const std::span<Complex> c(c_storage.data(), size), q(q_storage.data(), size);
  for (int64_t p = 0; p < pixels; ++p) {
    uint8_t& flags = solved.flags[p];
    for (int j = 0; j < size; ++j) {
      c[j] = {moments.real_plane(j)[p], j == 0 ? 0.0f : moments.imag_plane(j)[p]};
    }
    if (options.zeroth == ZerothMoment::kEstimate) c[0] = 0.0;
    if ((!moments.valid.empty() && moments.valid[p] == 0) || !AllFinite(c)) {
      flags |= kFlagInvalidInput;
      continue;
    }
    if (options.zeroth == ZerothMoment::kEstimate) {
      // c_0 is constructed to sit exactly at the bound, so it does not count as biased.
      c[0] = EstimateZerothMoment(c, options.bias_epsilon);
    }
    if (!(c[0].real() > 0.0)) {  // no light, or a negative measurement
      flags |= kFlagInvalidInput;
      continue;
    }
    if (Bias(c, options.bias_epsilon, options.bias_mode)) flags |= kFlagBiased;
    if (!Levinson(c, q)) {
      flags |= kFlagInvalidInput;
      continue;
    }
    for (int j = 0; j < size; ++j) {
      solved.c_real[j * pixels + p] = c[j].real();
      solved.c_imag[j * pixels + p] = c[j].imag();
      solved.q_real[j * pixels + p] = q[j].real();
      solved.q_imag[j * pixels + p] = q[j].imag();
    }
  }
  return solved;
}

PisarenkoImage EstimatePisarenko(const SolvedImage& solved) {
  const int64_t pixels = solved.geometry.pixel_count();
  const int m = solved.order;
  PisarenkoImage result;
  result.geometry = solved.geometry;
  result.order = m;
  result.phase.assign(m * pixels, kNaNf);
  result.weight.assign(m * pixels, kNaNf);
  result.uniform.assign(pixels, kNaNf);
  std::array<Complex, kMaxMoments> c_storage;
  const std::span<Complex> c(c_storage.data(), m + 1);
  PisarenkoEstimate estimate;
  for (int64_t p = 0; p < pixels; ++p) {
    if (!solved.valid(p)) continue;
    solved.moments(p, c);
    if (!Pisarenko(c, &estimate)) continue;
    result.uniform[p] = static_cast<float>(estimate.uniform);
    for (int l = 0; l < estimate.count; ++l) {
      result.phase[l * pixels + p] = static_cast<float>(estimate.phase[l]);
      result.weight[l * pixels + p] = static_cast<float>(estimate.weight[l]);
    }
  }
  return result;
}

std::vector<double> UniformPhases(int bins) {
  assert(bins > 0);
  std::vector<double> phases(bins);
  for (int n = 0; n < bins; ++n) phases[n] = kTwoPi * n / bins;
  return phases;
}

void DensitySlices(const SolvedImage& solved, std::span<const double> phases,
                   std::span<float> out) {
  const int64_t pixels = solved.geometry.pixel_count();
  assert(out.size() == phases.size() * pixels);
  std::array<Complex, kMaxMoments> q_storage;
  const std::span<Complex> q(q_storage.data(), solved.order + 1);
  for (int64_t p = 0; p < pixels; ++p) {
    if (!solved.valid(p)) {
      for (size_t n = 0; n < phases.size(); ++n) out[n * pixels + p] = kNaNf;
      continue;
    }
    solved.coefficients(p, q);
    for (size_t n = 0; n < phases.size(); ++n) {
      out[n * pixels + p] = static_cast<float>(MeseDensity(q, phases[n]));
    }
  }
}

void CumulativeSlices(const SolvedImage& solved, std::span<const double> phases,
                      std::span<float> out) {
  const int64_t pixels = solved.geometry.pixel_count();
  assert(out.size() == phases.size() * pixels);
  std::array<Complex, kMaxMoments> q_storage;
  const std::span<Complex> q(q_storage.data(), solved.order + 1);
  MeseCumulative cumulative;
  for (int64_t p = 0; p < pixels; ++p) {
    bool ok = solved.valid(p);
    if (ok) {
      solved.coefficients(p, q);
      ok = cumulative.Init(q);
    }
    for (size_t n = 0; n < phases.size(); ++n) {
      out[n * pixels + p] = ok ? static_cast<float>(cumulative(phases[n])) : kNaNf;
    }
  }
}

void BoundSlices(const SolvedImage& solved, double r, std::span<const double> phases,
                 std::span<float> lower, std::span<float> upper) {
  const int64_t pixels = solved.geometry.pixel_count();
  assert(lower.size() == phases.size() * pixels && upper.size() == lower.size());
  std::array<Complex, kMaxMoments> c_storage;
  const std::span<Complex> c(c_storage.data(), solved.order + 1);
  std::vector<double> low(phases.size()), high(phases.size());
  for (int64_t p = 0; p < pixels; ++p) {
    bool ok = solved.valid(p);
    if (ok) {
      solved.moments(p, c);
      ok = PoissonBounds(c, r, phases, low, high);
    }
    for (size_t n = 0; n < phases.size(); ++n) {
      lower[n * pixels + p] = ok ? static_cast<float>(low[n]) : kNaNf;
      upper[n * pixels + p] = ok ? static_cast<float>(high[n]) : kNaNf;
    }
  }
}

void MeseRange(const SolvedImage& solved, const RangeOptions& options, std::span<float> range_m,
               std::span<uint8_t> flags) {
  const int64_t pixels = solved.geometry.pixel_count();
  assert(range_m.size() == static_cast<size_t>(pixels) && flags.size() == range_m.size());
  std::array<Complex, kMaxMoments> q_storage;
  const std::span<Complex> q(q_storage.data(), solved.order + 1);
  for (int64_t p = 0; p < pixels; ++p) {
    range_m[p] = kNaNf;
    if (!solved.valid(p)) continue;
    solved.coefficients(p, q);
    const double phase = MeseFirstPeakPhase(q, options.threshold, options.search_bins);
    if (std::isnan(phase)) {
      flags[p] |= kFlagNoReturn;
    } else {
      range_m[p] = static_cast<float>(PhaseToRange(phase, options.base_frequency_hz));
    }
  }
}

void PisarenkoRange(const PisarenkoImage& pisarenko, const RangeOptions& options,
                    std::span<float> range_m, std::span<uint8_t> flags) {
  const int64_t pixels = pisarenko.geometry.pixel_count();
  assert(range_m.size() == static_cast<size_t>(pixels) && flags.size() == range_m.size());
  PisarenkoEstimate estimate;
  for (int64_t p = 0; p < pixels; ++p) {
    range_m[p] = kNaNf;
    if (std::isnan(pisarenko.uniform[p])) {
      // No estimate: an invalid pixel (already flagged) or a failed decomposition.
      if ((flags[p] & kFlagInvalidInput) == 0) flags[p] |= kFlagNoReturn;
      continue;
    }
    estimate.count = 0;
    for (int l = 0; l < pisarenko.order; ++l) {
      const float w = pisarenko.weight[l * pixels + p];
      if (std::isnan(w)) break;
      estimate.phase[l] = pisarenko.phase[l * pixels + p];
      estimate.weight[l] = w;
      ++estimate.count;
    }
    const double phase = PisarenkoFirstReturnPhase(estimate, options.threshold);
    if (std::isnan(phase)) {
      flags[p] |= kFlagNoReturn;
    } else {
      range_m[p] = static_cast<float>(PhaseToRange(phase, options.base_frequency_hz));
    }
  }
}

void SeparateDirectIndirect(const PisarenkoImage& pisarenko, double threshold,
                            std::span<float> direct, std::span<float> indirect) {
  const int64_t pixels = pisarenko.geometry.pixel_count();
  assert(direct.size() == static_cast<size_t>(pixels) && indirect.size() == direct.size());
  PisarenkoEstimate estimate;
  for (int64_t p = 0; p < pixels; ++p) {
    direct[p] = kNaNf;
    indirect[p] = kNaNf;
    if (std::isnan(pisarenko.uniform[p])) continue;
    estimate.count = 0;
    double total = 0.0;
    for (int l = 0; l < pisarenko.order; ++l) {
      const float w = pisarenko.weight[l * pixels + p];
      if (std::isnan(w)) break;
      estimate.phase[l] = pisarenko.phase[l * pixels + p];
      estimate.weight[l] = w;
      total += w;
      ++estimate.count;
    }
    int first = -1;
    PisarenkoFirstReturnPhase(estimate, threshold, &first);
    const double direct_weight = first >= 0 ? estimate.weight[first] : 0.0;
    direct[p] = static_cast<float>(direct_weight);
    indirect[p] = static_cast<float>(total - direct_weight);
  }
}

}  // namespace transient
