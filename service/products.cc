#include "transient/service/products.h"

#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "transient/reconstruct/moments.h"
#include "transient/reconstruct/physical_constants.h"

namespace transient::service {

std::vector<v1::Product> ProductSet::List() const {
  std::vector<v1::Product> list;
  for (int p = v1::Product_MIN; p <= v1::Product_MAX; ++p) {
    if (v1::Product_IsValid(p) && Has(static_cast<v1::Product>(p))) {
      list.push_back(static_cast<v1::Product>(p));
    }
  }
  return list;
}

double PhaseToTimeOfFlightNs(double phase_rad, double base_frequency_hz) {
  return PhaseToTimeOfFlight(phase_rad, base_frequency_hz) * 1e9;
}

double TimeOfFlightNsToPhase(double time_ns, double base_frequency_hz) {
  const double phase = std::fmod(TimeOfFlightToPhase(time_ns * 1e-9, base_frequency_hz), kTwoPi);
  return phase < 0.0 ? phase + kTwoPi : phase;
}

absl::StatusOr<std::vector<double>> ResolveSlicePhases(const v1::SliceSpec& spec,
                                                       double base_frequency_hz,
                                                       ImageGeometry geometry) {
  if (spec.bins() > static_cast<uint32_t>(kMaxSliceBins)) {
    return absl::InvalidArgumentError(
        absl::StrCat("slices.bins = ", spec.bins(), ": expected 1..", kMaxSliceBins));
  }
  std::vector<double> phases;
  if (spec.time_of_flight_ns_size() > 0) {
    if (spec.bin_indices_size() > 0 || spec.bins() > 0) {
      return absl::InvalidArgumentError(
          "slices: give either time_of_flight_ns or bins (with bin_indices), not both");
    }
    for (double t : spec.time_of_flight_ns()) {
      if (!std::isfinite(t) || t < 0.0) {
        return absl::InvalidArgumentError(absl::StrCat(
            "slices.time_of_flight_ns = ", t, ": expected a finite time >= 0 ns"));
      }
      phases.push_back(TimeOfFlightNsToPhase(t, base_frequency_hz));
    }
  } else {
    if (spec.bins() == 0) {
      return absl::InvalidArgumentError(absl::StrCat(
          "slices.bins = 0: expected 1..", kMaxSliceBins,
          " bins over one period, or a list of time_of_flight_ns"));
    }
    if (spec.bin_indices_size() > 0) {
      for (uint32_t n : spec.bin_indices()) {
        if (n >= spec.bins()) {
          return absl::InvalidArgumentError(absl::StrCat(
              "slices.bin_indices: ", n, " is not below slices.bins = ", spec.bins()));
        }
        phases.push_back(kTwoPi * n / spec.bins());
      }
    } else {
      phases = UniformPhases(static_cast<int>(spec.bins()));
    }
  }
  if (phases.size() > static_cast<size_t>(kMaxSlices)) {
    return absl::InvalidArgumentError(
        absl::StrCat("slices: ", phases.size(), " slices asked for; at most ", kMaxSlices));
  }
  const int64_t bytes = static_cast<int64_t>(phases.size()) * geometry.pixel_count() * 4;
  if (bytes > kMaxSliceBytesPerFrame) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "slices: %d slices of the %dx%d sensor take %d MiB per frame; at most %d MiB (%d "
        "slices)",
        phases.size(), geometry.width, geometry.height, bytes >> 20, kMaxSliceBytesPerFrame >> 20,
        kMaxSliceBytesPerFrame / (4 * geometry.pixel_count())));
  }
  return phases;
}

absl::StatusOr<MomentDepthSpec> ResolveMomentDepthSpec(const v1::MomentDepthRequest& request,
                                                       ImageGeometry sensor,
                                                       double unambiguous_range_m) {
  MomentDepthSpec spec;
  if (request.near_m() == 0.0 && request.far_m() == 0.0) {
    spec.far_m = unambiguous_range_m;
  } else {
    if (!std::isfinite(request.near_m()) || request.near_m() < 0.0) {
      return absl::InvalidArgumentError(absl::StrCat(
          "moment_depth.near_m = ", request.near_m(), ": expected a finite depth >= 0 m"));
    }
    if (!std::isfinite(request.far_m()) || !(request.far_m() > request.near_m())) {
      return absl::InvalidArgumentError(
          absl::StrCat("moment_depth.far_m = ", request.far_m(),
                       ": expected a finite depth above near_m = ", request.near_m(), " m"));
    }
    spec.near_m = request.near_m();
    spec.far_m = request.far_m();
  }
  if (request.has_sigma_px()) spec.sigma_px = request.sigma_px();
  switch (request.bits()) {
    case 0:
    case 64: spec.format = MomentMapFormat::kOptimized64; break;
    case 128: spec.format = MomentMapFormat::kFloat128; break;
    default:
      return absl::InvalidArgumentError(absl::StrCat(
          "moment_depth.bits = ", request.bits(), ": expected 64 (16UC4) or 128 (32FC4)"));
  }
  spec.from_returns = request.from_returns();
  // Validates sigma and the filter's width against the sensor, with messages naming them.
  absl::StatusOr<MomentDepthMapBuilder> builder =
      MomentDepthMapBuilder::Create(sensor, spec.MapOptions());
  if (!builder.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("moment_depth: ", builder.status().message()));
  }
  return spec;
}

ProductNeeds NeedsFor(const ProductSet& products) {
  return {.range = products.Has(v1::RANGE),
          .depth = products.Has(v1::DEPTH),
          .amplitude = products.Has(v1::AMPLITUDE),
          .c0 = products.Has(v1::C0),
          .direct_indirect = products.Has(v1::DIRECT_INDIRECT)};
}

}  // namespace transient::service
