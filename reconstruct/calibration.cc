// Per-pixel calibration against a Dirac at zero (thesis §8.3.2).
#include "transient/reconstruct/calibration.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_format.h"
#include "transient/reconstruct/moments.h"

namespace transient {
namespace {

// Frequencies written by a capture and read back from a file agree to far better than this; a
// different configuration differs by far more (acquisition.cc uses the same rule).
constexpr double kGainMatch = 1e-6;

bool NearFrequency(double a, double b) {
  return std::abs(a - b) <= kGainMatch * std::max(std::abs(a), std::abs(b));
}

std::string Hz(double hz) { return absl::StrFormat("%g MHz", hz / 1e6); }

std::string SamplingText(const ScheduleOptions& s) {
  if (s.sampling == SamplingScheme::kFourBucket) return std::string(SamplingSchemeName(s.sampling));
  return absl::StrCat(SamplingSchemeName(s.sampling), " (n_phi = ", s.phase_steps, ")");
}

std::string ZerothText(const ScheduleOptions& s) {
  if (s.zeroth != ZerothScheme::kLowFrequencyProxy) return std::string(ZerothSchemeName(s.zeroth));
  return absl::StrCat(ZerothSchemeName(s.zeroth), " at ", Hz(s.proxy_frequency_hz));
}

}  // namespace

absl::Status CalibrationTable::Validate() const {
  if (geometry.width <= 0 || geometry.height <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("calibration geometry ", geometry.width, "x",
                                                   geometry.height,
                                                   ". Violated constraint: width, height > 0"));
  }
  if (absl::Status status = schedule.Validate(); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("calibration schedule: ", status.message()));
  }
  if (order != schedule.order) {
    return absl::InvalidArgumentError(
        absl::StrCat("calibration order m = ", order,
                     ". Violated constraint: m == schedule.order = ", schedule.order));
  }
  if (!(base_frequency_hz > 0.0) || !NearFrequency(base_frequency_hz, schedule.base_frequency_hz)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "calibration base_frequency_hz = ", base_frequency_hz,
        ". Violated constraint: == schedule.base_frequency_hz = ", schedule.base_frequency_hz));
  }
  const size_t pixels = static_cast<size_t>(geometry.pixel_count());
  const size_t expected = static_cast<size_t>(order + 1) * pixels;
  if (real.size() != expected || imag.size() != expected) {
    return absl::InvalidArgumentError(absl::StrCat(
        "calibration planes hold ", real.size(), " real and ", imag.size(),
        " imaginary values. Violated constraint: both == (m+1)*width*height = ", expected));
  }
  if (valid.size() != pixels) {
    return absl::InvalidArgumentError(
        absl::StrCat("calibration valid plane holds ", valid.size(),
                     " values. Violated constraint: == width*height = ", pixels));
  }
  if (takes_averaged < 1) {
    return absl::InvalidArgumentError(absl::StrCat("calibration takes_averaged = ", takes_averaged,
                                                   ". Violated constraint: >= 1"));
  }
  return absl::OkStatus();
}

absl::Status CheckCalibrationMatches(const CalibrationTable& calibration,
                                     const ScheduleOptions& schedule, ImageGeometry geometry) {
  if (absl::Status status = calibration.Validate(); !status.ok()) return status;
  if (schedule.DeliversDepth()) {
    return absl::FailedPreconditionError(
        schedule.MissingHarmonicsText("a calibration table (per-pixel factors of the moments)"));
  }
  const ScheduleOptions& c = calibration.schedule;
  if (calibration.geometry != geometry) {
    return absl::FailedPreconditionError(absl::StrCat(
        "calibration is for ", calibration.geometry.width, "x", calibration.geometry.height,
        " pixels, the capture has ", geometry.width, "x", geometry.height));
  }
  if (!NearFrequency(calibration.base_frequency_hz, schedule.base_frequency_hz)) {
    return absl::FailedPreconditionError(
        absl::StrCat("calibration f = ", Hz(calibration.base_frequency_hz),
                     ", capture f = ", Hz(schedule.base_frequency_hz)));
  }
  if (calibration.order != schedule.order) {
    return absl::FailedPreconditionError(
        absl::StrCat("calibration m = ", calibration.order, ", capture m = ", schedule.order));
  }
  // The factors correct the residual of one effective modulation; another split is another one.
  const bool same_sampling =
      c.sampling == schedule.sampling &&
      (c.sampling == SamplingScheme::kFourBucket || c.phase_steps == schedule.phase_steps);
  if (!same_sampling) {
    return absl::FailedPreconditionError(absl::StrCat(
        "calibration sampling ", SamplingText(c), ", capture sampling ", SamplingText(schedule)));
  }
  if (c.buckets != schedule.buckets) {
    return absl::FailedPreconditionError(absl::StrCat("calibration with ", c.buckets,
                                                      "-step sampling, capture with ",
                                                      schedule.buckets, "-step"));
  }
  std::vector<int> calibrated = c.MeasuredHarmonics(), captured = schedule.MeasuredHarmonics();
  std::sort(calibrated.begin(), calibrated.end());
  std::sort(captured.begin(), captured.end());
  if (calibrated != captured) {
    return absl::FailedPreconditionError(
        absl::StrCat("calibration harmonics ", absl::StrJoin(calibrated, ", "),
                     ", capture harmonics ", absl::StrJoin(captured, ", ")));
  }
  // The reference of the factors (c_0 or |c_1|) depends on how c_0 is obtained.
  const bool same_zeroth = c.zeroth == schedule.zeroth &&
                           (c.zeroth != ZerothScheme::kLowFrequencyProxy ||
                            NearFrequency(c.proxy_frequency_hz, schedule.proxy_frequency_hz));
  if (!same_zeroth) {
    return absl::FailedPreconditionError(absl::StrCat("calibration zeroth moment ", ZerothText(c),
                                                      ", capture zeroth moment ",
                                                      ZerothText(schedule)));
  }
  return absl::OkStatus();
}

absl::StatusOr<CalibrationTable> EstimateCalibration(const MomentImage& dirac_at_zero,
                                                     const ScheduleOptions& schedule,
                                                     int takes_averaged, double min_signal) {
  if (absl::Status status = dirac_at_zero.Validate(); !status.ok()) return status;
  if (absl::Status status = schedule.Validate(); !status.ok()) return status;
  if (dirac_at_zero.order != schedule.order) {
    return absl::InvalidArgumentError(
        absl::StrCat("calibration moments have order m = ", dirac_at_zero.order,
                     ". Violated constraint: m == schedule order = ", schedule.order));
  }
  if (takes_averaged < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("takes_averaged = ", takes_averaged, ". Violated constraint: >= 1"));
  }
  if (!std::isfinite(min_signal) || min_signal < 0.0) {
    return absl::InvalidArgumentError(
        absl::StrCat("min_signal = ", min_signal, ". Violated constraint: finite and >= 0"));
  }
  const int m = schedule.order;
  const int64_t pixels = dirac_at_zero.geometry.pixel_count();
  CalibrationTable table;
  table.geometry = dirac_at_zero.geometry;
  table.order = m;
  table.base_frequency_hz = schedule.base_frequency_hz;
  table.schedule = schedule;
  table.takes_averaged = takes_averaged;
  table.real.assign(static_cast<size_t>((m + 1) * pixels), kNaNf);
  table.imag.assign(static_cast<size_t>((m + 1) * pixels), kNaNf);
  table.valid.assign(static_cast<size_t>(pixels), 0);
  const bool measured = schedule.zeroth != ZerothScheme::kEstimated;
  // Without c_0 the reference is the modulus of the lowest harmonic measured (c_1 for 1..m).
  const std::vector<int> harmonics = schedule.MeasuredHarmonics();
  const int lowest = *std::min_element(harmonics.begin(), harmonics.end());
  std::vector<bool> measured_harmonic(static_cast<size_t>(m) + 1, false);
  for (int j : harmonics) measured_harmonic[static_cast<size_t>(j)] = true;

  Complex c[kMaxMoments];
  for (int64_t p = 0; p < pixels; ++p) {
    if (!dirac_at_zero.valid.empty() && dirac_at_zero.valid[static_cast<size_t>(p)] == 0) continue;
    bool finite = true;
    for (int j = 0; j <= m; ++j) {
      c[j] =
          Complex(dirac_at_zero.real_plane(j)[p], j == 0 ? 0.0f : dirac_at_zero.imag_plane(j)[p]);
      finite = finite && IsFinite(c[j]);
    }
    if (!finite) continue;
    const double reference = measured ? c[0].real() : std::abs(c[lowest]);
    if (!(reference > min_signal) || !(reference > 0.0)) continue;
    // A harmonic that measured nothing cannot be corrected (its factor would be infinite).
    bool usable = true;
    for (int j : harmonics) usable = usable && std::abs(c[j]) > 0.0;
    if (!usable) continue;
    table.valid[static_cast<size_t>(p)] = 1;
    table.real[static_cast<size_t>(p)] = 1.0f;
    table.imag[static_cast<size_t>(p)] = 0.0f;
    for (int j = 1; j <= m; ++j) {
      // A harmonic the schedule does not measure holds 0 whatever its factor: 1.
      const Complex k = measured_harmonic[static_cast<size_t>(j)] ? reference / c[j] : Complex(1.0);
      const size_t q = static_cast<size_t>(j * pixels + p);
      table.real[q] = static_cast<float>(k.real());
      table.imag[q] = static_cast<float>(k.imag());
    }
  }
  return table;
}

absl::Status ApplyCalibration(const CalibrationTable& calibration, MomentImage* moments) {
  if (absl::Status status = calibration.Validate(); !status.ok()) return status;
  if (absl::Status status = moments->Validate(); !status.ok()) return status;
  if (calibration.geometry != moments->geometry) {
    return absl::FailedPreconditionError(absl::StrCat(
        "calibration is for ", calibration.geometry.width, "x", calibration.geometry.height,
        " pixels, the moments have ", moments->geometry.width, "x", moments->geometry.height));
  }
  if (calibration.order != moments->order) {
    return absl::FailedPreconditionError(
        absl::StrCat("calibration m = ", calibration.order, ", moments m = ", moments->order));
  }
  const int m = moments->order;
  const int64_t pixels = moments->geometry.pixel_count();
  if (moments->valid.empty()) moments->valid.assign(static_cast<size_t>(pixels), 1);
  for (int j = 1; j <= m; ++j) {
    const float* kr = calibration.real.data() + j * pixels;
    const float* ki = calibration.imag.data() + j * pixels;
    float* re = moments->real_plane(j);
    float* im = moments->imag_plane(j);
    for (int64_t p = 0; p < pixels; ++p) {
      const float r = re[p] * kr[p] - im[p] * ki[p];
      const float i = re[p] * ki[p] + im[p] * kr[p];
      re[p] = r;
      im[p] = i;
    }
  }
  // Unusable calibration pixels carry NaN factors: the products above are NaN already; mark
  // them invalid so that nothing downstream mistakes them for data.
  for (int64_t p = 0; p < pixels; ++p) {
    if (calibration.valid[static_cast<size_t>(p)] != 0) continue;
    moments->valid[static_cast<size_t>(p)] = 0;
    moments->real_plane(0)[p] = kNaNf;
  }
  return absl::OkStatus();
}

}  // namespace transient
