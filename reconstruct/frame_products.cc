// The products of a solved frame, computed once for everything its consumers asked for.
#include "transient/reconstruct/frame_products.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <utility>

#include "transient/reconstruct/moments.h"

namespace transient {
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

// A pixel's Pisarenko returns as depths and weights (ReturnsAsDepth), for maps of returns.
struct ReturnDepths {
  int order = 0;
  std::vector<float> depth_m, weight;
};

// Builds the moment depth maps of `needs` into `out`: of `depth_m`, or of `returns` for specs
// from_returns (left out when `returns` is null: the caller refused those). Builders come from
// `builders`, or from a set made for this frame.
void BuildMomentDepthMaps(const ProductNeeds& needs, ImageGeometry geometry,
                          std::span<const float> depth_m, const ReturnDepths* returns,
                          MomentDepthBuilders* builders, FrameProducts* out) {
  MomentDepthBuilders this_frame;
  if (builders == nullptr) builders = &this_frame;
  builders->Retain(needs.moment_depth);
  for (const MomentDepthSpec& spec : needs.moment_depth) {
    if (spec.from_returns && returns == nullptr) continue;
    MomentDepthMapBuilder* builder = builders->For(geometry, spec);
    if (builder == nullptr) continue;  // an invalid spec: its consumers get no map
    auto map = std::make_shared<MomentDepthMap>();
    const absl::Status status =
        spec.from_returns
            ? builder->BuildFromReturns(returns->order, returns->depth_m, returns->weight,
                                        map.get())
            : builder->Build(depth_m, map.get());
    if (status.ok()) out->moment_depth[spec] = std::move(map);
  }
}

}  // namespace

void MomentDepthBuilders::Retain(const std::vector<MomentDepthSpec>& specs) {
  std::erase_if(builders_, [&](const auto& entry) {
    return std::find(specs.begin(), specs.end(), entry.first) == specs.end();
  });
}

MomentDepthMapBuilder* MomentDepthBuilders::For(ImageGeometry geometry,
                                                const MomentDepthSpec& spec) {
  auto it = builders_.find(spec);
  if (it == builders_.end() || (it->second.has_value() && it->second->geometry() != geometry)) {
    absl::StatusOr<MomentDepthMapBuilder> created =
        MomentDepthMapBuilder::Create(geometry, spec.MapOptions());
    std::optional<MomentDepthMapBuilder> builder;
    if (created.ok()) builder.emplace(*std::move(created));
    it = builders_.insert_or_assign(spec, std::move(builder)).first;
  }
  return it->second.has_value() ? &*it->second : nullptr;
}

void MergeNoReturn(std::span<const uint8_t> solved_flags, std::span<const uint8_t> range_flags,
                   std::span<const float> range_m, std::span<uint8_t> out) {
  for (size_t p = 0; p < out.size(); ++p) {
    const bool unexplained_nan =
        std::isnan(range_m[p]) && (solved_flags[p] & kFlagInvalidInput) == 0;
    out[p] = static_cast<uint8_t>(solved_flags[p] | (range_flags[p] & kFlagNoReturn) |
                                  (unexplained_nan ? kFlagNoReturn : 0));
  }
}

std::shared_ptr<const FrameProducts> ComputeProducts(std::shared_ptr<const SolvedImage> solved,
                                                     const CameraInfo& camera,
                                                     const ProductOptions& options,
                                                     const ProductNeeds& needs,
                                                     uint64_t sequence,
                                                     MomentDepthBuilders* builders) {
  auto out = std::make_shared<FrameProducts>();
  const SolvedImage& s = *solved;
  const size_t pixels = static_cast<size_t>(s.geometry.pixel_count());
  out->sequence = sequence;
  out->geometry = s.geometry;
  out->order = s.order;
  out->base_frequency_hz = options.base_frequency_hz;
  out->flags = s.flags;

  bool moments_of_depth = false, moments_of_returns = false;
  for (const MomentDepthSpec& spec : needs.moment_depth) {
    (spec.from_returns ? moments_of_returns : moments_of_depth) = true;
  }
  const bool need_depth = needs.depth || moments_of_depth;
  const bool need_range = needs.range || need_depth;
  const bool pisarenko_method = options.range_method == RangeMethod::kPisarenko;
  const bool need_pisarenko = needs.pisarenko || needs.direct_indirect || moments_of_returns ||
                              needs.pisarenko_range || (need_range && pisarenko_method);
  if (need_pisarenko) {
    out->pisarenko = std::make_shared<const PisarenkoImage>(EstimatePisarenko(s));
  }
  const RangeOptions range_options{.base_frequency_hz = options.base_frequency_hz,
                                   .threshold = options.threshold};
  if (needs.pisarenko_range || (need_range && pisarenko_method)) {
    std::vector<uint8_t> range_flags = s.flags;
    out->pisarenko_range_m.resize(pixels);
    PisarenkoRange(*out->pisarenko, range_options, out->pisarenko_range_m, range_flags);
    if (need_range && pisarenko_method) {
      out->range_m = out->pisarenko_range_m;
      MergeNoReturn(s.flags, range_flags, out->range_m, out->flags);
    }
  }
  if (need_range && !pisarenko_method) {
    std::vector<uint8_t> range_flags = s.flags;
    out->range_m.resize(pixels);
    MeseRange(s, range_options, out->range_m, range_flags);
    MergeNoReturn(s.flags, range_flags, out->range_m, out->flags);
  }
  if (need_depth) {
    out->depth_m.resize(pixels);
    DepthFromRange(s.geometry, camera.intrinsics, out->range_m, out->depth_m);
  }
  if (needs.amplitude) {
    out->amplitude.resize(pixels);
    Amplitude(s, out->amplitude);
  }
  if (needs.c0) out->c0 = ZerothPlane(s);
  if (needs.direct_indirect) {
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
  ReturnDepths returns;
  if (moments_of_returns) {
    returns.order = out->pisarenko->order;
    ReturnsAsDepth(*out->pisarenko, camera, options.base_frequency_hz, options.threshold,
                   &returns.depth_m, &returns.weight);
  }
  BuildMomentDepthMaps(needs, s.geometry, out->depth_m, moments_of_returns ? &returns : nullptr,
                       builders, out.get());
  out->solved = std::move(solved);
  return out;
}

std::shared_ptr<const FrameProducts> ComputeUnwrappedProducts(
    const MomentImage& moments, const CameraInfo& camera, const UnwrapOptions& unwrap,
    const ProductNeeds& needs, uint64_t sequence, MomentDepthBuilders* builders) {
  auto out = std::make_shared<FrameProducts>();
  out->sequence = sequence;
  out->geometry = moments.geometry;
  out->order = moments.order;
  out->base_frequency_hz = unwrap.base_frequency_hz;
  std::vector<float> amplitude;
  const absl::Status status =
      UnwrapImage(moments, unwrap, &out->range_m, &amplitude, &out->confidence, &out->flags);
  assert(status.ok());
  (void)status;
  bool moments_of_depth = false;
  for (const MomentDepthSpec& spec : needs.moment_depth) moments_of_depth |= !spec.from_returns;
  if (needs.depth || moments_of_depth) {
    out->depth_m.resize(out->range_m.size());
    DepthFromRange(moments.geometry, camera.intrinsics, out->range_m, out->depth_m);
  }
  if (needs.amplitude) out->amplitude = std::move(amplitude);
  // Maps of returns need the Pisarenko returns: refused by the caller, left out here.
  BuildMomentDepthMaps(needs, moments.geometry, out->depth_m, nullptr, builders, out.get());
  return out;
}

std::shared_ptr<const FrameProducts> ComputeDepthProducts(
    std::span<const float> depth_m, std::span<const float> amplitude, const CameraInfo& camera,
    const ProductNeeds& needs, uint64_t sequence, MomentDepthBuilders* builders) {
  const ImageGeometry geometry = camera.geometry;
  const size_t pixels = static_cast<size_t>(geometry.pixel_count());
  assert(depth_m.size() == pixels);
  assert(amplitude.empty() || amplitude.size() == pixels);
  auto out = std::make_shared<FrameProducts>();
  out->sequence = sequence;
  out->geometry = geometry;
  out->depth_m.resize(pixels);
  out->flags.assign(pixels, 0);
  for (size_t p = 0; p < pixels; ++p) {
    const float z = depth_m[p];
    const bool valid = std::isfinite(z) && z > 0.0f;
    out->depth_m[p] = valid ? z : std::numeric_limits<float>::quiet_NaN();
    if (!valid) out->flags[p] = kFlagNoReturn;
  }
  out->range_m.resize(pixels);
  RangeFromDepth(geometry, camera.intrinsics, out->depth_m, out->range_m);
  if (needs.amplitude && !amplitude.empty()) out->amplitude.assign(amplitude.begin(), amplitude.end());
  // No returns without the moment reconstruction: maps of returns are left out.
  BuildMomentDepthMaps(needs, geometry, out->depth_m, nullptr, builders, out.get());
  return out;
}

}  // namespace transient
