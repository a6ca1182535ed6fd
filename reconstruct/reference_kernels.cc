// The scalar reference kernels: plain per-pixel loops over the functions of this folder,
// single-threaded and in double precision. They are the oracle of the optimized kernels.
#include <array>
#include <cassert>
#include <cmath>
#include <limits>
#include <vector>

#include "kernels_internal.h"
#include "transient/reconstruct/bounds.h"
#include "transient/reconstruct/cumulative.h"
#include "transient/reconstruct/kernels.h"
#include "transient/reconstruct/levinson.h"
#include "transient/reconstruct/mese.h"
#include "transient/reconstruct/pisarenko.h"
#include "transient/reconstruct/range.h"

namespace transient {
namespace {


bool AllFinite(std::span<const Complex> c) {
  for (const Complex& v : c) {
    if (!std::isfinite(v.real()) || !std::isfinite(v.imag())) return false;
  }
  return true;
}

// Levinson's positive-definiteness test of C(c) - eps c_0 I: true iff lambda_min > eps c_0.
bool ClearlyAboveBound(std::span<const Complex> c, double epsilon) {
  std::array<Complex, kMaxMoments> shifted, q;
  const size_t size = c.size();
  for (size_t j = 0; j < size; ++j) shifted[j] = c[j];
  shifted[0] = c[0].real() * (1.0 - epsilon);
  return Levinson(std::span<const Complex>(shifted.data(), size),
                  std::span<Complex>(q.data(), size));
}

}  // namespace

namespace internal {

void PrepareSolved(const MomentImage& moments, SolvedImage* solved) {
  const int64_t pixels = moments.geometry.pixel_count();
  const size_t values = static_cast<size_t>((moments.order + 1) * pixels);
  solved->geometry = moments.geometry;
  solved->order = moments.order;
  solved->c_real.resize(values);
  solved->c_imag.resize(values);
  solved->q_real.resize(values);
  solved->q_imag.resize(values);
  solved->flags.assign(pixels, 0);
  if (!moments.flags.empty()) {
    for (int64_t p = 0; p < pixels; ++p) solved->flags[p] = moments.flags[p] & kMomentImageFlags;
  }
}

PisarenkoImage AllocatePisarenko(const SolvedImage& solved) {
  const int64_t pixels = solved.geometry.pixel_count();
  PisarenkoImage result;
  result.geometry = solved.geometry;
  result.order = solved.order;
  result.phase.assign(solved.order * pixels, kNaNf);
  result.weight.assign(solved.order * pixels, kNaNf);
  result.uniform.assign(pixels, kNaNf);
  return result;
}

void SolvePixels(const MomentImage& moments, const SolveOptions& options, bool quick_bias_check,
                 int64_t begin, int64_t end, SolvedImage* solved) {
  const int64_t pixels = moments.geometry.pixel_count();
  const int size = moments.order + 1;
  std::array<Complex, kMaxMoments> c_storage, q_storage;
  const std::span<Complex> c(c_storage.data(), size), q(q_storage.data(), size);
  for (int64_t p = begin; p < end; ++p) {
    uint8_t& flags = solved->flags[p];
    for (int j = 0; j < size; ++j) {
      c[j] = {moments.real_plane(j)[p], j == 0 ? 0.0f : moments.imag_plane(j)[p]};
    }
    if (options.zeroth == ZerothMoment::kEstimate) c[0] = 0.0;
    bool valid = (moments.valid.empty() || moments.valid[p] != 0) && AllFinite(c);
    if (valid && options.zeroth == ZerothMoment::kEstimate) {
      // c_0 is constructed to sit exactly at the bound, so it does not count as biased.
      c[0] = EstimateZerothMoment(c, options.bias_epsilon);
    }
    valid = valid && c[0].real() > 0.0;  // else no light, or a negative measurement
    if (valid) {
      const bool skip_bias = quick_bias_check && options.zeroth == ZerothMoment::kMeasured &&
                             ClearlyAboveBound(c, options.bias_epsilon);
      if (!skip_bias && Bias(c, options.bias_epsilon, options.bias_mode)) flags |= kFlagBiased;
      valid = Levinson(c, q);
    }
    if (!valid) {
      flags |= kFlagInvalidInput;
      for (int j = 0; j < size; ++j) {
        solved->c_real[j * pixels + p] = solved->c_imag[j * pixels + p] = kNaN;
        solved->q_real[j * pixels + p] = solved->q_imag[j * pixels + p] = kNaN;
      }
      continue;
    }
    for (int j = 0; j < size; ++j) {
      solved->c_real[j * pixels + p] = c[j].real();
      solved->c_imag[j * pixels + p] = c[j].imag();
      solved->q_real[j * pixels + p] = q[j].real();
      solved->q_imag[j * pixels + p] = q[j].imag();
    }
  }
}

void PisarenkoPixels(const SolvedImage& solved, int64_t begin, int64_t end, PisarenkoImage* result,
                     const PisarenkoSearchGrid* grid) {
  const int64_t pixels = solved.geometry.pixel_count();
  std::array<Complex, kMaxMoments> c_storage;
  const std::span<Complex> c(c_storage.data(), solved.order + 1);
  PisarenkoEstimate estimate;
  for (int64_t p = begin; p < end; ++p) {
    if (!solved.valid(p)) continue;
    solved.moments(p, c);
    const bool fast = grid != nullptr && PisarenkoByLevinson(c, *grid, &estimate);
    if (!fast && !Pisarenko(c, &estimate)) continue;
    result->uniform[p] = static_cast<float>(estimate.uniform);
    for (int l = 0; l < estimate.count; ++l) {
      result->phase[l * pixels + p] = static_cast<float>(estimate.phase[l]);
      result->weight[l * pixels + p] = static_cast<float>(estimate.weight[l]);
    }
  }
}

void CumulativePixels(const SolvedImage& solved, std::span<const double> phases, int64_t begin,
                      int64_t end, std::span<float> out) {
  const int64_t pixels = solved.geometry.pixel_count();
  std::array<Complex, kMaxMoments> q_storage;
  const std::span<Complex> q(q_storage.data(), solved.order + 1);
  MeseCumulative cumulative;
  for (int64_t p = begin; p < end; ++p) {
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

void BoundPixels(const SolvedImage& solved, double r, std::span<const double> phases, int64_t begin,
                 int64_t end, std::span<float> lower, std::span<float> upper) {
  const int64_t pixels = solved.geometry.pixel_count();
  std::array<Complex, kMaxMoments> c_storage;
  const std::span<Complex> c(c_storage.data(), solved.order + 1);
  std::vector<double> low(phases.size()), high(phases.size());
  for (int64_t p = begin; p < end; ++p) {
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

void MeseRangePixels(const SolvedImage& solved, const RangeOptions& options, int64_t begin,
                     int64_t end, std::span<float> range_m, std::span<uint8_t> flags) {
  std::array<Complex, kMaxMoments> q_storage;
  const std::span<Complex> q(q_storage.data(), solved.order + 1);
  const int bins = options.SearchBins(solved.order);
  for (int64_t p = begin; p < end; ++p) {
    range_m[p] = kNaNf;
    if (!solved.valid(p)) continue;
    solved.coefficients(p, q);
    const double phase = MeseFirstPeakPhase(q, options.threshold, bins);
    if (std::isnan(phase)) {
      flags[p] |= kFlagNoReturn;
    } else {
      range_m[p] = static_cast<float>(PhaseToRange(phase, options.base_frequency_hz));
    }
  }
}

}  // namespace internal

namespace reference {

void Solve(const MomentImage& moments, const SolveOptions& options, SolvedImage* solved) {
  assert(moments.Validate().ok() && options.Validate().ok());
  internal::PrepareSolved(moments, solved);
  internal::SolvePixels(moments, options, /*quick_bias_check=*/false, 0,
                        moments.geometry.pixel_count(), solved);
}

PisarenkoImage EstimatePisarenko(const SolvedImage& solved) {
  PisarenkoImage result = internal::AllocatePisarenko(solved);
  internal::PisarenkoPixels(solved, 0, solved.geometry.pixel_count(), &result);
  return result;
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
  assert(out.size() == phases.size() * solved.geometry.pixel_count());
  internal::CumulativePixels(solved, phases, 0, solved.geometry.pixel_count(), out);
}

void BoundSlices(const SolvedImage& solved, double r, std::span<const double> phases,
                 std::span<float> lower, std::span<float> upper) {
  const int64_t pixels = solved.geometry.pixel_count();
  assert(lower.size() == phases.size() * pixels && upper.size() == lower.size());
  internal::BoundPixels(solved, r, phases, 0, pixels, lower, upper);
}

void MeseRange(const SolvedImage& solved, const RangeOptions& options, std::span<float> range_m,
               std::span<uint8_t> flags) {
  assert(range_m.size() == static_cast<size_t>(solved.geometry.pixel_count()) &&
         flags.size() == range_m.size());
  internal::MeseRangePixels(solved, options, 0, solved.geometry.pixel_count(), range_m, flags);
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

}  // namespace reference
}  // namespace transient
