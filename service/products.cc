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
namespace {


std::vector<float> ZerothPlane(const SolvedImage& solved) {
  const int64_t pixels = solved.geometry.pixel_count();
  std::vector<float> c0(static_cast<size_t>(pixels));
  for (int64_t p = 0; p < pixels; ++p) {
    c0[p] = solved.valid(p) ? static_cast<float>(solved.c_real[p])
                            : std::numeric_limits<float>::quiet_NaN();
  }
  return c0;
}

// The Pisarenko returns of every pixel as depths and weights (planar, m planes, as
// MomentDepthMapBuilder::BuildFromReturns takes them): a return's phase is its range
// (c phi / (4 pi f)), its depth that times the ray factor. Returns weaker than `threshold` times
// the pixel's largest weight, NaN padding and invalid pixels get weight 0 (left out).
void ReturnsAsDepth(const PisarenkoImage& pisarenko, const CameraInfo& camera,
                    double base_frequency_hz, double threshold, std::vector<float>* depth_m,
                    std::vector<float>* weight) {
  const int64_t pixels = pisarenko.geometry.pixel_count();
  const int m = pisarenko.order;
  const double metres_per_radian = PhaseToRange(1.0, base_frequency_hz);
  depth_m->assign(static_cast<size_t>(m * pixels), std::numeric_limits<float>::quiet_NaN());
  weight->assign(static_cast<size_t>(m * pixels), 0.0f);
  for (int64_t p = 0; p < pixels; ++p) {
    float largest = 0.0f;
    for (int r = 0; r < m; ++r) {
      const float w = pisarenko.weight[r * pixels + p];
      if (w > largest) largest = w;  // false for NaN
    }
    if (!(largest > 0.0f)) continue;
    const int width = camera.geometry.width;
    const double factor =
        PixelRay(camera.intrinsics, static_cast<double>(p % width), static_cast<double>(p / width)).z;
    for (int r = 0; r < m; ++r) {
      const size_t i = static_cast<size_t>(r * pixels + p);
      const float w = pisarenko.weight[i];
      const float phase = pisarenko.phase[i];
      if (!(w >= threshold * largest) || !std::isfinite(phase)) continue;
      (*depth_m)[i] = static_cast<float>(phase * metres_per_radian * factor);
      (*weight)[i] = w;
    }
  }
}

}  // namespace

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

std::shared_ptr<const FrameProducts> ComputeProducts(std::shared_ptr<const SolvedImage> solved,
                                                     const CameraInfo& camera,
                                                     const ProductOptions& options,
                                                     const ProductNeeds& needs,
                                                     uint64_t sequence) {
  auto out = std::make_shared<FrameProducts>();
  const SolvedImage& s = *solved;
  const size_t pixels = static_cast<size_t>(s.geometry.pixel_count());
  out->sequence = sequence;
  out->geometry = s.geometry;
  out->order = s.order;
  out->base_frequency_hz = options.base_frequency_hz;
  out->flags = s.flags;

  const ProductSet& p = needs.products;
  bool moments_of_depth = false, moments_of_returns = false;
  if (p.Has(v1::MOMENT_DEPTH)) {
    for (const MomentDepthSpec& spec : needs.moment_depth) {
      (spec.from_returns ? moments_of_returns : moments_of_depth) = true;
    }
  }
  const bool need_depth = p.Has(v1::DEPTH) || moments_of_depth;
  const bool need_range = p.Has(v1::RANGE) || need_depth;
  const bool need_pisarenko = p.Has(v1::DIRECT_INDIRECT) || moments_of_returns ||
                              (need_range && options.range_method == RangeMethod::kPisarenko);
  if (need_pisarenko) {
    out->pisarenko = std::make_shared<const PisarenkoImage>(EstimatePisarenko(s));
  }
  if (need_range) {
    const RangeOptions range_options{.base_frequency_hz = options.base_frequency_hz,
                                     .threshold = options.threshold};
    out->range_m.resize(pixels);
    if (options.range_method == RangeMethod::kPisarenko) {
      PisarenkoRange(*out->pisarenko, range_options, out->range_m, out->flags);
    } else {
      MeseRange(s, range_options, out->range_m, out->flags);
    }
    if (need_depth) {
      out->depth_m.resize(pixels);
      DepthFromRange(s.geometry, camera.intrinsics, out->range_m, out->depth_m);
    }
  }
  if (p.Has(v1::AMPLITUDE)) {
    out->amplitude.resize(pixels);
    Amplitude(s, out->amplitude);
  }
  if (p.Has(v1::C0)) out->c0 = ZerothPlane(s);
  if (p.Has(v1::DIRECT_INDIRECT)) {
    out->direct.resize(pixels);
    out->indirect.resize(pixels);
    SeparateDirectIndirect(*out->pisarenko, options.threshold, out->direct, out->indirect);
  }
  for (const auto& [phases, need] : needs.slice_phases) {
    SliceImages& images = out->slices[phases];
    if (need.density) {
      images.density.resize(phases.size() * pixels);
      DensitySlices(s, phases, images.density);
    }
    if (need.cumulative) {
      images.cumulative.resize(phases.size() * pixels);
      CumulativeSlices(s, phases, images.cumulative);
    }
  }
  if (p.Has(v1::MOMENT_DEPTH)) {
    std::vector<float> return_depth, return_weight;
    if (moments_of_returns) {
      ReturnsAsDepth(*out->pisarenko, camera, options.base_frequency_hz, options.threshold,
                     &return_depth, &return_weight);
    }
    for (const MomentDepthSpec& spec : needs.moment_depth) {
      absl::StatusOr<MomentDepthMapBuilder> builder =
          MomentDepthMapBuilder::Create(s.geometry, spec.MapOptions());
      if (!builder.ok()) continue;  // ResolveMomentDepthSpec refused such specs
      auto map = std::make_shared<MomentDepthMap>();
      const absl::Status status =
          spec.from_returns
              ? builder->BuildFromReturns(out->pisarenko->order, return_depth, return_weight,
                                          map.get())
              : builder->Build(out->depth_m, map.get());
      if (status.ok()) out->moment_depth[spec] = std::move(map);
    }
  }
  out->solved = std::move(solved);
  return out;
}

}  // namespace transient::service
