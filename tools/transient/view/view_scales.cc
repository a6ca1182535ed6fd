#include "tools/transient/view/view_scales.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include "absl/status/status.h"
#include "transient/reconstruct/camera_model.h"

namespace transient::tools {

absl::StatusOr<ViewScales> ChooseViewScales(const ViewArgs& args, const TransientFrameSource& source,
                                        const ViewPlan& plan, const CommandHooks& hooks,
                                        DepthPercentiles* depth) {
  // The per-pixel plot scales its own axes; the colour-mapped pictures share these.
  const bool density =
      (plan.slices || plan.video || !plan.streak_rows.empty()) && !args.density_scale.has_value();
  const bool cumulative = plan.cumulative;
  const bool amplitude = plan.images || plan.point_cloud || plan.moment_depth;
  const bool range = plan.images;
  const bool optical_depth = plan.moment_depth;
  const bool direct_indirect = plan.direct_indirect;
  ViewScales scales;
  if (args.density_scale.has_value()) scales.density = *args.density_scale;
  if (!density && !cumulative && !amplitude && !range && !direct_indirect && !optical_depth) {
    return scales;
  }

  ProductSet wanted;
  if (density) wanted.set(static_cast<int>(Product::kDensity));
  if (cumulative) wanted.set(static_cast<int>(Product::kCumulative));
  if (amplitude) wanted.set(static_cast<int>(Product::kZerothMoment));
  if (range || optical_depth) wanted.set(static_cast<int>(Product::kRange));
  if (direct_indirect) {
    wanted.set(static_cast<int>(Product::kPisarenkoDirect));
    wanted.set(static_cast<int>(Product::kPisarenkoIndirect));
  }
  const int64_t pixels = source.geometry().pixel_count();
  const int64_t bin_values = source.frames() * std::max(source.bins(), 1) * pixels;
  const int64_t plane_values = source.frames() * pixels;
  const auto stride = [](int64_t values) {
    return std::max<int64_t>(1, (values + kMaxScaleSamples - 1) / kMaxScaleSamples);
  };
  ScaleSampler density_samples(stride(bin_values)), cumulative_samples(stride(bin_values));
  ScaleSampler amplitude_samples(stride(plane_values)), range_samples(stride(plane_values));
  ScaleSampler direct_indirect_samples(stride(2 * plane_values));
  ScaleSampler depth_samples(stride(plane_values));
  TransientFrame frame;
  for (int64_t k = 0; k < source.frames(); ++k) {
    if (hooks.cancelled()) {
      return absl::CancelledError("interrupted; nothing written");
    }
    if (absl::Status status = source.ReadFrame(k, wanted, &frame); !status.ok()) return status;
    if (density) density_samples.Add(frame.density);
    if (cumulative) cumulative_samples.Add(frame.cumulative);
    if (amplitude) amplitude_samples.Add(frame.c0);
    if (range) range_samples.Add(frame.range_m);
    if (optical_depth) {
      depth_samples.Add(DepthFromRange(frame.geometry, *plan.intrinsics, frame.range_m));
    }
    if (direct_indirect) {
      direct_indirect_samples.Add(frame.pisarenko_direct);
      direct_indirect_samples.Add(frame.pisarenko_indirect);
    }
  }
  if (density) scales.density = PositiveScale(density_samples.Quantile(kScaleQuantile, 1.0));
  if (cumulative) {
    scales.cumulative = PositiveScale(cumulative_samples.Quantile(kScaleQuantile, 1.0));
  }
  if (amplitude) scales.amplitude = PositiveScale(amplitude_samples.Quantile(kScaleQuantile, 1.0));
  if (direct_indirect) {
    scales.direct_indirect =
        PositiveScale(direct_indirect_samples.Quantile(kScaleQuantile, 1.0));
  }
  if (optical_depth) {
    // NaN when no pixel has a depth: ResolveMomentSetup then asks for every option.
    const double nan = std::numeric_limits<double>::quiet_NaN();
    depth->low_m = depth_samples.Quantile(0.005, nan);
    depth->high_m = depth_samples.Quantile(0.95, nan);
    depth->top_m = depth_samples.Quantile(0.995, nan);
  }
  if (range) {
    scales.range_min_m = range_samples.Quantile(1.0 - kScaleQuantile, 0.0);
    scales.range_max_m = range_samples.Quantile(kScaleQuantile, 1.0);
    if (!(scales.range_max_m > scales.range_min_m)) {
      scales.range_max_m = scales.range_min_m + 1.0;
    }
  }
  return scales;
}

}  // namespace transient::tools
