#include "tools/transient/view/moment_setup.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "transient/reconstruct/smoothing.h"

namespace transient::tools {
namespace {

// The defaults of ResolveMomentSetup (header): margins as fractions of the depths.
constexpr double kMarginOfFarSurface = 0.1;  // m = 0.1 d_hi
constexpr double kNearPad = 0.85, kFarPad = 1.15;
constexpr double kRangeStepM = 0.1;
constexpr double kPlaneLeftFraction = 0.2, kPlaneRightFraction = 0.8, kPlaneHeight = 0.5;
constexpr double kBackdropLeftFraction = 0.025, kBackdropRightFraction = 0.975;
constexpr double kBackdropHeight = 0.95;
constexpr double kViewpointOffset = 0.3;  // times the backdrop's mean depth
}  // namespace

absl::Status MomentPictureOptions::Validate() const {
  if (!enabled) {
    const std::pair<const char*, bool> given[] = {{"--near", near_m.has_value()},
                                                  {"--far", far_m.has_value()},
                                                  {"--plane-depth", !plane_depth_m.empty()},
                                                  {"--sphere", !sphere_m.empty()},
                                                  {"--backdrop-depth", !backdrop_depth_m.empty()},
                                                  {"--moment-video", video}};
    for (const auto& [name, is_given] : given) {
      if (is_given) {
        return absl::InvalidArgumentError(
            absl::StrCat(name, ": a moment-depth option; give --moment-depth too"));
      }
    }
    return absl::OkStatus();
  }
  if (near_m.has_value() && !(std::isfinite(*near_m) && *near_m >= 0.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--near = ", *near_m, ": expected a finite depth >= 0 m"));
  }
  if (far_m.has_value() && !(std::isfinite(*far_m) && *far_m > 0.0)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--far = ", *far_m, ": expected a finite depth > 0 m"));
  }
  if (near_m.has_value() && far_m.has_value() && !(*far_m > *near_m)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--far = ", *far_m, ": expected far > --near = ", *near_m, " m"));
  }
  if (blur_px.empty() || static_cast<int>(blur_px.size()) > kMaxBlurs) {
    return absl::InvalidArgumentError(absl::StrCat("--blur = ", absl::StrJoin(blur_px, ","),
                                                   ": expected 1 to ", kMaxBlurs, " sigmas"));
  }
  for (double sigma : blur_px) {
    if (!(std::isfinite(sigma) && sigma > 0.0)) {
      return absl::InvalidArgumentError(
          absl::StrCat("--blur = ", sigma, ": expected Gaussian sigmas > 0 px"));
    }
  }
  if (upscale < 1 || upscale > kMaxUpscale) {
    return absl::InvalidArgumentError(
        absl::StrCat("--upscale = ", upscale, ": expected an integer in 1..", kMaxUpscale));
  }
  const auto two_depths = [](const char* name, const std::vector<double>& values) {
    if (values.empty()) return absl::OkStatus();
    if (values.size() != 2 || !std::all_of(values.begin(), values.end(),
                                           [](double v) { return std::isfinite(v) && v > 0.0; })) {
      return absl::InvalidArgumentError(absl::StrCat(name, " = ", absl::StrJoin(values, ","),
                                                     ": expected two depths LEFT,RIGHT > 0 m"));
    }
    return absl::OkStatus();
  };
  if (absl::Status status = two_depths("--plane-depth", plane_depth_m); !status.ok()) {
    return status;
  }
  if (absl::Status status = two_depths("--backdrop-depth", backdrop_depth_m); !status.ok()) {
    return status;
  }
  if (!sphere_m.empty() &&
      !((sphere_m.size() == 2 || sphere_m.size() == 4) &&
        std::all_of(sphere_m.begin(), sphere_m.end(), [](double v) { return std::isfinite(v); }) &&
        sphere_m[1] > 0.0 && sphere_m[0] > sphere_m[1])) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--sphere = ", absl::StrJoin(sphere_m, ","),
        ": expected Z,R or Z,R,X,Y with Z > R > 0 m (the whole sphere in front of the camera)"));
  }
  return absl::OkStatus();
}

absl::Status CheckMomentOptionsForImage(const MomentPictureOptions& options,
                                        ImageGeometry geometry) {
  if (!options.enabled) return absl::OkStatus();
  for (double sigma : options.blur_px) {
    const int radius = GaussianRadius(sigma);
    const int64_t width = 2 * int64_t{radius} + 1;
    if (width > geometry.width || width > geometry.height) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--blur = ", sigma, ": the Gaussian (radius ceil(3 sigma) = ", radius, " px, ", width,
          " px wide) is wider than the ", geometry.width, "x", geometry.height,
          " px image; expected sigma <= ",
          absl::StrFormat("%.3g", (std::min(geometry.width, geometry.height) - 1) / 6.0), " px"));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<MomentSetup> ResolveMomentSetup(const MomentPictureOptions& options,
                                               ImageGeometry geometry, const PinholeIntrinsics& intrinsics,
                                               const DepthPercentiles& percentiles) {
  MomentSetup setup;
  setup.geometry = geometry;
  setup.intrinsics = intrinsics;
  setup.upscale = options.upscale;
  setup.blur_px = options.blur_px;
  setup.percentiles = percentiles;
  setup.range_given = options.near_m.has_value() && options.far_m.has_value();
  setup.placement_given = !options.plane_depth_m.empty() && !options.sphere_m.empty() &&
                          !options.backdrop_depth_m.empty();
  const DepthPercentiles& d = percentiles;
  const bool known = std::isfinite(d.low_m) && std::isfinite(d.high_m) && std::isfinite(d.top_m) &&
                     d.low_m > 0.0 && d.high_m > 0.0;
  if (!known && !(setup.range_given && setup.placement_given)) {
    return absl::InvalidArgumentError(
        "--moment-depth: no pixel of the frames drawn has a depth, so there are no defaults: "
        "give --near, --far, --plane-depth, --sphere and --backdrop-depth");
  }

  // Defaults (header): the scene's depths with a margin, rounded outward to 0.1 m.
  const double margin = kMarginOfFarSurface * d.high_m;
  DepthNormalisation& range = setup.normalisation;
  range.near_m = options.near_m.value_or(
      std::max(kRangeStepM, std::floor(kNearPad * d.low_m / kRangeStepM) * kRangeStepM));
  range.far_m = options.far_m.value_or(std::ceil(kFarPad * d.top_m / kRangeStepM) * kRangeStepM);
  if (!(range.far_m > range.near_m)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "--near/--far: depth range %g..%g m is empty (near %s, far %s); expected far > near",
        range.near_m, range.far_m, options.near_m ? "given" : "default",
        options.far_m ? "given" : "default"));
  }

  const double width = geometry.width;
  setup.plane = {
      .left_depth_m =
          options.plane_depth_m.empty() ? d.high_m - 2.0 * margin : options.plane_depth_m[0],
      .right_depth_m = options.plane_depth_m.empty() ? d.high_m + margin : options.plane_depth_m[1],
      .left_column = kPlaneLeftFraction * width - 0.5,
      .right_column = kPlaneRightFraction * width - 0.5,
      .height_fraction = kPlaneHeight};
  setup.sphere = {
      .depth_m = options.sphere_m.empty() ? d.high_m + 0.5 * margin : options.sphere_m[0],
      .radius_m = options.sphere_m.empty() ? margin : options.sphere_m[1],
      .column = options.sphere_m.size() == 4 ? options.sphere_m[2] : 0.5 * (width - 1),
      .row = options.sphere_m.size() == 4 ? options.sphere_m[3] : 0.5 * (geometry.height - 1)};
  setup.backdrop = {.left_depth_m = options.backdrop_depth_m.empty()
                                        ? 0.5 * (d.low_m + d.high_m) - margin
                                        : options.backdrop_depth_m[0],
                    .right_depth_m = options.backdrop_depth_m.empty() ? d.high_m + margin
                                                                      : options.backdrop_depth_m[1],
                    .left_column = kBackdropLeftFraction * width - 0.5,
                    .right_column = kBackdropRightFraction * width - 0.5,
                    .height_fraction = kBackdropHeight};
  setup.viewpoint_offset_m =
      kViewpointOffset * 0.5 * (setup.backdrop.left_depth_m + setup.backdrop.right_depth_m);

  // Nothing may reach behind far: the map holds no depth beyond it (DepthMoments clamps).
  const std::string far_text = absl::StrCat(options.far_m ? "--far = " : "far = ", range.far_m,
                                            " m", options.far_m ? "" : " (default)");
  const auto check = [&](const char* option, bool given, const char* what, double deepest) {
    if (deepest <= range.far_m) return absl::OkStatus();
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: the %s (%s) reaches Z = %g m, behind %s: the moment map knows nothing beyond far; "
        "place it nearer with %s or widen --far",
        given ? option : "--far", what, given ? "given" : "default placement", deepest, far_text,
        option));
  };
  for (absl::Status status :
       {check("--plane-depth", !options.plane_depth_m.empty(), "virtual plane",
              std::max(setup.plane.left_depth_m, setup.plane.right_depth_m)),
        check("--sphere", !options.sphere_m.empty(), "virtual sphere's rim", setup.sphere.depth_m),
        check("--backdrop-depth", !options.backdrop_depth_m.empty(), "backdrop",
              std::max(setup.backdrop.left_depth_m, setup.backdrop.right_depth_m))}) {
    if (!status.ok()) return status;
  }
  for (auto [what, depth] :
       {std::pair{"plane", std::min(setup.plane.left_depth_m, setup.plane.right_depth_m)},
        std::pair{"backdrop",
                  std::min(setup.backdrop.left_depth_m, setup.backdrop.right_depth_m)}}) {
    if (!(depth > 0.0)) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "the default %s reaches Z = %g m, behind the camera: give its depths", what, depth));
    }
  }

  setup.compare_blur = 0;
  for (int i = 1; i < static_cast<int>(setup.blur_px.size()); ++i) {
    if (std::abs(setup.blur_px[i] - kCompareBlurPx) <
        std::abs(setup.blur_px[setup.compare_blur] - kCompareBlurPx)) {
      setup.compare_blur = i;
    }
  }
  return setup;
}

std::string FormatMomentSetup(const MomentSetup& setup) {
  const DepthPercentiles& d = setup.percentiles;
  return absl::StrFormat(
      "moment depth: depth %.3g..%.3g m -> [-1, 1] (%s; depth percentiles 0.5/95/99.5: "
      "%.3g/%.3g/%.3g m), plane Z %.3g..%.3g m, sphere Z %.3g m r %.3g m at pixel %.3g,%.3g, "
      "backdrop Z %.3g..%.3g m seen from x = %.3g m; sigma %s px; %dx upscale",
      setup.normalisation.near_m, setup.normalisation.far_m,
      setup.range_given ? "--near/--far" : "default", d.low_m, d.high_m, d.top_m,
      setup.plane.left_depth_m, setup.plane.right_depth_m, setup.sphere.depth_m,
      setup.sphere.radius_m, setup.sphere.column, setup.sphere.row, setup.backdrop.left_depth_m,
      setup.backdrop.right_depth_m, setup.viewpoint_offset_m, absl::StrJoin(setup.blur_px, ", "),
      setup.upscale);
}

}  // namespace transient::tools
