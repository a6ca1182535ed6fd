#include "transient/service/products.h"

#include <cmath>
#include <numbers>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace transient::service {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

std::vector<float> ZerothPlane(const SolvedImage& solved) {
  const int64_t pixels = solved.geometry.pixel_count();
  std::vector<float> c0(static_cast<size_t>(pixels));
  for (int64_t p = 0; p < pixels; ++p) {
    c0[p] = solved.valid(p) ? static_cast<float>(solved.c_real[p])
                            : std::numeric_limits<float>::quiet_NaN();
  }
  return c0;
}

// Z = range * cos(angle between the pixel's ray and the optical axis), pinhole model.
std::vector<float> DepthFromRange(std::span<const float> range_m, const CameraInfo& camera) {
  const ImageGeometry g = camera.geometry;
  std::vector<float> depth(range_m.size());
  for (int y = 0; y < g.height; ++y) {
    const double v = (y - camera.cy) / camera.fy;
    for (int x = 0; x < g.width; ++x) {
      const double u = (x - camera.cx) / camera.fx;
      const int64_t p = int64_t{y} * g.width + x;
      depth[p] = static_cast<float>(range_m[p] / std::sqrt(u * u + v * v + 1.0));
    }
  }
  return depth;
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

const char* ProductName(v1::Product product) {
  switch (product) {
    case v1::RANGE: return "range";
    case v1::DEPTH: return "depth";
    case v1::AMPLITUDE: return "amplitude";
    case v1::C0: return "c0";
    case v1::FLAGS: return "flags";
    case v1::MOMENT_STATE: return "moment_state";
    case v1::SLICES: return "slices";
    case v1::CUMULATIVE: return "cumulative";
    case v1::DIRECT_INDIRECT: return "direct_indirect";
    default: return "unspecified";
  }
}

double PhaseToTimeOfFlightNs(double phase_rad, double base_frequency_hz) {
  return phase_rad / (kTwoPi * base_frequency_hz) * 1e9;
}

double TimeOfFlightNsToPhase(double time_ns, double base_frequency_hz) {
  const double phase = std::fmod(kTwoPi * base_frequency_hz * time_ns * 1e-9, kTwoPi);
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
  const bool need_range = p.Has(v1::RANGE) || p.Has(v1::DEPTH);
  const bool need_pisarenko = p.Has(v1::DIRECT_INDIRECT) ||
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
    if (p.Has(v1::DEPTH)) out->depth_m = DepthFromRange(out->range_m, camera);
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
  out->solved = std::move(solved);
  return out;
}

}  // namespace transient::service
