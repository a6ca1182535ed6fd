// Moment-depth pictures: virtual objects and a virtual backdrop tested against the camera's depth
// through filtered moment maps (thesis ch. 4), drawn as labelled figures.
#include "tools/transient/moment_pictures.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <system_error>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "transient/reconstruct/smoothing.h"

namespace transient::tools {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// The defaults of ResolveMomentSetup (header): margins as fractions of the depths.
constexpr double kMarginOfFarSurface = 0.1;  // m = 0.1 d_hi
constexpr double kNearPad = 0.85, kFarPad = 1.15;
constexpr double kRangeStepM = 0.1;
constexpr double kPlaneLeftFraction = 0.2, kPlaneRightFraction = 0.8, kPlaneHeight = 0.5;
constexpr double kBackdropLeftFraction = 0.025, kBackdropRightFraction = 0.975;
constexpr double kBackdropHeight = 0.95;
constexpr double kViewpointOffset = 0.3;  // times the backdrop's mean depth
// The backdrop's viewer sees a wider field than the camera (focal lengths times this), so the
// whole backdrop fits with some margin.
constexpr double kViewerZoom = 0.9;
constexpr int kPlaneChecks = 8;  // checks across the plane's width

// Okabe-Ito colours: the plane's checks and the sphere.
constexpr Rgb8 kPlaneColourA = {0, 158, 115};
constexpr Rgb8 kPlaneColourB = {86, 180, 233};
constexpr Rgb8 kSphereColour = {230, 159, 0};
constexpr Rgb8 kBackgroundSwatch = {150, 150, 150};

// The 64-bit map of thesis §4.1.4 is the one the daemon streams; its decoded texels take the
// bias of eq. 4.4's adapted b* (kQuantized16MomentBias).
constexpr MomentMapFormat kFormat = MomentMapFormat::kOptimized64;

// The rectangle of a VirtualPlane in the optical frame: corners a + s (b - a) + t (0, 1, 0),
// s in [0, 1], |t| <= half_height.
struct PlaneGeometry {
  Vec3 a, b, normal;
  double half_height = 0.0;
  double length = 0.0;  // |b - a|
};

PlaneGeometry GeometryOf(const VirtualPlane& plane, const MomentSetup& setup) {
  const PinholeIntrinsics& k = setup.intrinsics;
  const double mean_depth = 0.5 * (plane.left_depth_m + plane.right_depth_m);
  const double middle_row = 0.5 * (setup.geometry.height - 1);
  const double y = (middle_row - k.cy) / k.fy * mean_depth;
  PlaneGeometry g;
  g.a = {(plane.left_column - k.cx) / k.fx * plane.left_depth_m, y, plane.left_depth_m};
  g.b = {(plane.right_column - k.cx) / k.fx * plane.right_depth_m, y, plane.right_depth_m};
  const Vec3 e = g.b - g.a;
  g.length = e.norm();
  g.normal = Vec3{-e.z, 0.0, e.x} * (1.0 / g.length);  // e x (0, 1, 0)
  g.half_height = 0.5 * plane.height_fraction * setup.geometry.height / k.fy * mean_depth;
  return g;
}

// Where the ray origin + lambda dir (lambda > 0) meets the rectangle: the point and its (s, t).
bool HitPlane(const PlaneGeometry& g, const Vec3& origin, const Vec3& dir, Vec3* point, double* s,
              double* t) {
  const double denominator = g.normal.dot(dir);
  if (std::abs(denominator) < 1e-12) return false;
  const double lambda = g.normal.dot(g.a - origin) / denominator;
  if (!(lambda > 0.0)) return false;
  *point = origin + dir * lambda;
  *s = (*point - g.a).dot(g.b - g.a) / (g.length * g.length);
  *t = point->y - g.a.y;
  return *s >= 0.0 && *s <= 1.0 && std::abs(*t) <= g.half_height;
}

Rgb8 Shade(Rgb8 colour, double lambert) {
  const double f = 0.45 + 0.55 * std::clamp(lambert, 0.0, 1.0);
  return {static_cast<uint8_t>(std::lround(colour.r * f)),
          static_cast<uint8_t>(std::lround(colour.g * f)),
          static_cast<uint8_t>(std::lround(colour.b * f))};
}

// Camera coordinates of output pixel U at `upscale` output pixels per camera pixel.
double CameraCoordinate(int output, int upscale) { return (output + 0.5) / upscale - 0.5; }

Fragments EmptyFragments(const MomentSetup& setup) {
  Fragments f;
  f.geometry = setup.output_geometry();
  const size_t n = static_cast<size_t>(f.geometry.pixel_count());
  f.depth_m.assign(n, kNaN);
  f.x.assign(n, kNaN);
  f.y.assign(n, kNaN);
  return f;
}

// Camera rays through every output pixel: fills x, y and calls hit(p, dir) for the rest.
template <typename Hit>
Fragments CastFromCamera(const MomentSetup& setup, Hit hit) {
  Fragments f = EmptyFragments(setup);
  f.colour.assign(f.depth_m.size(), Rgb8{});
  const PinholeIntrinsics& k = setup.intrinsics;
  const int width = f.geometry.width;
  for (int v = 0; v < f.geometry.height; ++v) {
    for (int u = 0; u < width; ++u) {
      const size_t p = static_cast<size_t>(v) * width + u;
      const double x = CameraCoordinate(u, setup.upscale);
      const double y = CameraCoordinate(v, setup.upscale);
      f.x[p] = static_cast<float>(x);
      f.y[p] = static_cast<float>(y);
      const Vec3 dir{(x - k.cx) / k.fx, (y - k.cy) / k.fy, 1.0};
      double depth = 0.0;
      Rgb8 colour;
      if (hit(dir, &depth, &colour)) {
        f.depth_m[p] = static_cast<float>(depth);
        f.colour[p] = colour;
      }
    }
  }
  return f;
}

std::string SigmaText(double sigma_px) { return absl::StrFormat("%g", sigma_px); }

float Bilinear(std::span<const float> plane, ImageGeometry g, float x, float y) {
  const float fx = std::floor(x), fy = std::floor(y);
  const float wx = x - fx, wy = y - fy;
  const int x0 = std::clamp(static_cast<int>(fx), 0, g.width - 1);
  const int x1 = std::clamp(static_cast<int>(fx) + 1, 0, g.width - 1);
  const int y0 = std::clamp(static_cast<int>(fy), 0, g.height - 1);
  const int y1 = std::clamp(static_cast<int>(fy) + 1, 0, g.height - 1);
  const auto at = [&](int xx, int yy) { return plane[static_cast<size_t>(yy) * g.width + xx]; };
  return (1 - wy) * ((1 - wx) * at(x0, y0) + wx * at(x1, y0)) +
         wy * ((1 - wx) * at(x0, y1) + wx * at(x1, y1));
}

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

const char* OcclusionTestName(OcclusionTest test) {
  switch (test) {
    case OcclusionTest::kHardDepth:
      return "hard depth test";
    case OcclusionTest::kVariance:
      return "VSM";
    case OcclusionTest::kHamburger4:
      return "Hamburger 4MSM";
    case OcclusionTest::kHausdorff4:
      return "Hausdorff 4MSM";
  }
  return "?";
}

const char* VirtualObjectName(VirtualObject object) {
  return object == VirtualObject::kPlane ? "virtual plane" : "virtual sphere";
}

Fragments RenderPlane(const MomentSetup& setup) {
  const PlaneGeometry g = GeometryOf(setup.plane, setup);
  const double check = g.length / kPlaneChecks;
  return CastFromCamera(setup, [&](const Vec3& dir, double* depth, Rgb8* colour) {
    Vec3 point;
    double s = 0.0, t = 0.0;
    if (!HitPlane(g, {}, dir, &point, &s, &t)) return false;
    *depth = point.z;
    const int i = static_cast<int>(std::floor(s * kPlaneChecks));
    const int j = static_cast<int>(std::floor((t + g.half_height) / check));
    const double lambert = std::abs(g.normal.dot(dir)) / dir.norm();
    *colour = Shade((i + j) % 2 == 0 ? kPlaneColourA : kPlaneColourB, lambert);
    return true;
  });
}

Fragments RenderSphere(const MomentSetup& setup) {
  const PinholeIntrinsics& k = setup.intrinsics;
  const double z = setup.sphere.depth_m, r = setup.sphere.radius_m;
  const Vec3 centre{(setup.sphere.column - k.cx) / k.fx * z, (setup.sphere.row - k.cy) / k.fy * z,
                    z};
  return CastFromCamera(setup, [&](const Vec3& dir, double* depth, Rgb8* colour) {
    // |lambda dir - centre| = r, nearest root (the camera is outside the sphere: Z > R).
    const double a = dir.dot(dir), b = dir.dot(centre), c = centre.dot(centre) - r * r;
    const double discriminant = b * b - a * c;
    if (discriminant < 0.0) return false;
    const double lambda = (b - std::sqrt(discriminant)) / a;
    if (!(lambda > 0.0)) return false;
    const Vec3 point = dir * lambda;
    *depth = point.z;
    const Vec3 normal = (point - centre) * (1.0 / r);
    *colour = Shade(kSphereColour, -normal.dot(dir) / std::sqrt(a));
    return true;
  });
}

Fragments RenderBackdrop(const MomentSetup& setup) {
  Fragments f = EmptyFragments(setup);
  const PlaneGeometry g = GeometryOf(setup.backdrop, setup);
  const PinholeIntrinsics& k = setup.intrinsics;
  // The viewer at (offset, 0, 0) looks at the backdrop's centre, turned about the y axis only.
  const Vec3 viewer{setup.viewpoint_offset_m, 0.0, 0.0};
  const Vec3 centre = (g.a + g.b) * 0.5;
  const double dx = centre.x - viewer.x, dz = centre.z - viewer.z;
  const double length = std::hypot(dx, dz);
  const Vec3 forward{dx / length, 0.0, dz / length};
  const Vec3 right{forward.z, 0.0, -forward.x};
  const Vec3 down{0.0, 1.0, 0.0};
  const int width = f.geometry.width;
  for (int v = 0; v < f.geometry.height; ++v) {
    for (int u = 0; u < width; ++u) {
      const double xv = CameraCoordinate(u, setup.upscale);
      const double yv = CameraCoordinate(v, setup.upscale);
      const Vec3 dir = right * ((xv - k.cx) / (kViewerZoom * k.fx)) +
                       down * ((yv - k.cy) / (kViewerZoom * k.fy)) + forward;
      Vec3 point;
      double s = 0.0, t = 0.0;
      if (!HitPlane(g, viewer, dir, &point, &s, &t) || !(point.z > 0.0)) continue;
      // Its projection into the camera, the light's shadow map; outside it nothing is known.
      const double x = k.fx * point.x / point.z + k.cx;
      const double y = k.fy * point.y / point.z + k.cy;
      if (!(x >= -0.5 && x <= setup.geometry.width - 0.5 && y >= -0.5 &&
            y <= setup.geometry.height - 0.5)) {
        continue;
      }
      const size_t p = static_cast<size_t>(v) * width + u;
      f.depth_m[p] = static_cast<float>(point.z);
      f.x[p] = static_cast<float>(x);
      f.y[p] = static_cast<float>(y);
    }
  }
  return f;
}

absl::StatusOr<MomentPictures> MomentPictures::Create(const MomentSetup& setup) {
  MomentPictures pictures(setup);
  MomentDepthMapOptions options{
      .normalisation = setup.normalisation, .sigma_px = 0.0, .format = kFormat};
  absl::StatusOr<MomentDepthMapBuilder> unfiltered =
      MomentDepthMapBuilder::Create(setup.geometry, options);
  if (!unfiltered.ok()) return unfiltered.status();
  pictures.unfiltered_builder_.emplace(*std::move(unfiltered));
  for (double sigma : setup.blur_px) {
    options.sigma_px = sigma;
    absl::StatusOr<MomentDepthMapBuilder> builder =
        MomentDepthMapBuilder::Create(setup.geometry, options);
    if (!builder.ok()) {
      return absl::Status(builder.status().code(),
                          absl::StrCat("--blur = ", sigma, ": ", builder.status().message()));
    }
    pictures.builders_.push_back(*std::move(builder));
  }
  pictures.maps_.resize(setup.blur_px.size());
  pictures.texels_.resize(setup.blur_px.size());
  pictures.plane_ = RenderPlane(setup);
  pictures.sphere_ = RenderSphere(setup);
  pictures.backdrop_ = RenderBackdrop(setup);
  return pictures;
}

absl::Status MomentPictures::SetFrame(int64_t index, std::span<const float> depth_m,
                                      std::span<const float> c0, double c0_scale) {
  const int64_t pixels = setup_.geometry.pixel_count();
  if (static_cast<int64_t>(depth_m.size()) != pixels || static_cast<int64_t>(c0.size()) != pixels) {
    return absl::InvalidArgumentError(absl::StrCat("moment pictures: expected ", pixels,
                                                   " depths and c0 values, got ", depth_m.size(),
                                                   " and ", c0.size()));
  }
  index_ = index;
  depth_m_.assign(depth_m.begin(), depth_m.end());
  grey_.resize(c0.size());
  const double scale = c0_scale > 0.0 && std::isfinite(c0_scale) ? c0_scale : 1.0;
  for (size_t p = 0; p < c0.size(); ++p) {
    grey_[p] =
        std::isfinite(c0[p]) ? std::clamp(static_cast<float>(c0[p] / scale), 0.0f, 1.0f) : kNaN;
  }
  if (absl::Status status = unfiltered_builder_->Build(depth_m, &unfiltered_); !status.ok()) {
    return status;
  }
  for (size_t b = 0; b < builders_.size(); ++b) {
    if (absl::Status status = builders_[b].Build(depth_m, &maps_[b]); !status.ok()) {
      return status;
    }
    std::vector<float>& texels = texels_[b];
    texels.resize(static_cast<size_t>(4 * pixels));
    for (int y = 0; y < setup_.geometry.height; ++y) {
      for (int x = 0; x < setup_.geometry.width; ++x) {
        const PowerMomentsF t = maps_[b].Texel(x, y);
        const size_t p = static_cast<size_t>(y) * setup_.geometry.width + x;
        for (int k = 0; k < 4; ++k) texels[4 * p + k] = t[k + 1];
      }
    }
  }
  return absl::OkStatus();
}

std::vector<float> MomentPictures::Visibility(const Fragments& fragments, OcclusionTest test,
                                              int blur) const {
  const ImageGeometry g = setup_.geometry;
  const int64_t n = fragments.geometry.pixel_count();
  std::vector<float> visibility(static_cast<size_t>(n), kNaN);
  const std::vector<float>* texels =
      test == OcclusionTest::kHardDepth ? nullptr : &texels_[static_cast<size_t>(blur)];
  const MomentBias bias = kQuantized16MomentBias;
  const DepthNormalisation range = setup_.normalisation;
#pragma omp parallel for schedule(static)
  for (int64_t i = 0; i < n; ++i) {
    const float z_f = fragments.depth_m[i];
    if (std::isnan(z_f)) continue;
    const float x = fragments.x[i], y = fragments.y[i];
    if (test == OcclusionTest::kHardDepth) {
      // The nearest texel's depth, compared without any bias: jagged edges, and acne where a
      // fragment lies on a real surface.
      const int xi = std::clamp(static_cast<int>(std::lround(x)), 0, g.width - 1);
      const int yi = std::clamp(static_cast<int>(std::lround(y)), 0, g.height - 1);
      const float real = depth_m_[static_cast<size_t>(yi) * g.width + xi];
      visibility[i] = real < z_f ? 0.0f : 1.0f;  // NaN (no depth) hides nothing
      continue;
    }
    // Bilinear interpolation of the decoded texels; decoding Θ is affine (thesis eq. 4.4), so
    // this equals a renderer's hardware-filtered fetch of the 16-bit channels.
    const float fx = std::floor(x), fy = std::floor(y);
    const float wx = x - fx, wy = y - fy;
    const int x0 = std::clamp(static_cast<int>(fx), 0, g.width - 1);
    const int x1 = std::clamp(static_cast<int>(fx) + 1, 0, g.width - 1);
    const int y0 = std::clamp(static_cast<int>(fy), 0, g.height - 1);
    const int y1 = std::clamp(static_cast<int>(fy) + 1, 0, g.height - 1);
    const std::array<std::pair<size_t, float>, 4> taps = {{
        {static_cast<size_t>(y0) * g.width + x0, (1 - wx) * (1 - wy)},
        {static_cast<size_t>(y0) * g.width + x1, wx * (1 - wy)},
        {static_cast<size_t>(y1) * g.width + x0, (1 - wx) * wy},
        {static_cast<size_t>(y1) * g.width + x1, wx * wy},
    }};
    PowerMomentsF b = {1.0f, 0.0f, 0.0f, 0.0f, 0.0f};
    for (const auto& [p, w] : taps) {
      for (int k = 0; k < 4; ++k) b[k + 1] += w * (*texels)[4 * p + k];
    }
    const float z = static_cast<float>(range.Normalise(z_f));
    float occlusion = 0.0f;
    switch (test) {
      case OcclusionTest::kVariance:
        occlusion = VarianceOcclusion(b, z, bias);
        break;
      case OcclusionTest::kHamburger4:
        occlusion = Hamburger4Occlusion(b, z, bias);
        break;
      case OcclusionTest::kHausdorff4:
        occlusion = Hausdorff4Occlusion(b, z, bias);
        break;
      case OcclusionTest::kHardDepth:
        break;
    }
    visibility[i] = 1.0f - occlusion;
  }
  return visibility;
}

std::string MomentPictures::Subtitle(int blur) const {
  const DepthNormalisation& range = setup_.normalisation;
  const std::string filter =
      blur < 0 ? "unfiltered"
               : absl::StrCat("Gaussian sigma = ", SigmaText(setup_.blur_px[blur]), " px");
  return absl::StrFormat("frame %d, 64-bit moments (thesis eq. 4.4), %s, depth %g..%g m -> [-1, 1]",
                         index_, filter, range.near_m, range.far_m);
}

ImageFigure MomentPictures::MapFigure(int blur) const {
  const MomentDepthMap& m = map(blur);
  const int64_t pixels = setup_.geometry.pixel_count();
  std::vector<uint8_t> rgb(static_cast<size_t>(3 * pixels));
  for (int64_t p = 0; p < pixels; ++p) {
    for (int c = 0; c < 3; ++c) rgb[3 * p + c] = static_cast<uint8_t>(m.quantized[4 * p + c] >> 8);
  }
  return {.title = blur < 0 ? "moment depth map as colour, before the blur"
                            : absl::StrCat("moment depth map as colour, after a Gaussian blur of "
                                           "sigma = ",
                                           SigmaText(setup_.blur_px[blur]), " px"),
          .geometry = setup_.geometry,
          .rgb = std::move(rgb),
          .x = {.label = "x [px]", .begin = -0.5, .end = setup_.geometry.width - 0.5},
          .y = {.label = "y [px]", .begin = -0.5, .end = setup_.geometry.height - 0.5},
          .legend = {{{255, 0, 0}, "R: 1.5 b1 - 2 b3 + 0.5"},
                     {{0, 255, 0}, "G: 4 b2 - 4 b4"},
                     {{0, 0, 255}, "B: 0.866 b1 - 0.385 b3 + 0.5"},
                     {{255, 255, 255}, "(4th: 0.5 b2 + 0.5 b4)"},
                     {{255, 255, 255}, "b_j: powers of z in [-1, 1]"}},
          .subtitle = Subtitle(blur)};
}

std::vector<uint8_t> MomentPictures::Composite(const Fragments& object,
                                               const std::vector<float>& visibility) const {
  const int64_t n = object.geometry.pixel_count();
  std::vector<uint8_t> rgb(static_cast<size_t>(3 * n));
  for (int64_t i = 0; i < n; ++i) {
    const float grey = Bilinear(grey_, setup_.geometry, object.x[i], object.y[i]);
    const float background = std::isnan(grey) ? kNoValueGrey.r : 255.0f * grey;
    const float v = std::isnan(visibility[i]) ? 0.0f : visibility[i];
    const Rgb8 c = object.colour[i];
    rgb[3 * i] = static_cast<uint8_t>(std::lround(v * c.r + (1 - v) * background));
    rgb[3 * i + 1] = static_cast<uint8_t>(std::lround(v * c.g + (1 - v) * background));
    rgb[3 * i + 2] = static_cast<uint8_t>(std::lround(v * c.b + (1 - v) * background));
  }
  return rgb;
}

ImageFigure MomentPictures::CompositeFigure(VirtualObject which, OcclusionTest test,
                                            int blur) const {
  const Fragments& object = fragments(which);
  std::vector<LegendEntry> legend;
  if (which == VirtualObject::kPlane) {
    legend.push_back(
        {kPlaneColourA, absl::StrFormat("virtual plane, Z %.3g..%.3g m", setup_.plane.left_depth_m,
                                        setup_.plane.right_depth_m)});
  } else {
    legend.push_back(
        {kSphereColour, absl::StrFormat("virtual sphere, Z %.3g m, r %.3g m", setup_.sphere.depth_m,
                                        setup_.sphere.radius_m)});
  }
  legend.push_back({kBackgroundSwatch, "real scene: amplitude c0"});
  legend.push_back({{255, 255, 255}, "blend: visibility 1 - G"});
  const std::string how =
      test == OcclusionTest::kHardDepth
          ? absl::StrFormat("frame %d, nearest depth texel, no filter, %dx upscale", index_,
                            setup_.upscale)
          : absl::StrCat(Subtitle(blur),
                         absl::StrFormat(", %dx upscale, bilinear", setup_.upscale));
  return {.title = absl::StrCat(VirtualObjectName(which),
                                " occluded by the real scene: ", OcclusionTestName(test)),
          .geometry = object.geometry,
          .rgb = Composite(object, Visibility(object, test, blur)),
          .x = {.label = "x [px]", .begin = -0.5, .end = setup_.geometry.width - 0.5},
          .y = {.label = "y [px]", .begin = -0.5, .end = setup_.geometry.height - 0.5},
          .legend = std::move(legend),
          .zoom_x = 1,
          .zoom_y = 1,
          .subtitle = how};
}

ImageFigure MomentPictures::BackdropFigure(OcclusionTest test, int blur) const {
  const ColourScale scale{.label = "light visibility 1 - G", .min = 0.0, .max = 1.0};
  const std::vector<float> visibility = Visibility(backdrop_, test, blur);
  const std::string how = test == OcclusionTest::kHardDepth
                              ? absl::StrFormat("frame %d, nearest depth texel, no filter", index_)
                              : Subtitle(blur);
  return {
      .title =
          absl::StrCat("shadow of the real scene on a virtual backdrop: ", OcclusionTestName(test)),
      .geometry = backdrop_.geometry,
      .rgb = scale.Colours(visibility),
      .x = {.label = "x [px] (virtual view)", .begin = -0.5, .end = setup_.geometry.width - 0.5},
      .y = {.label = "y [px] (virtual view)", .begin = -0.5, .end = setup_.geometry.height - 0.5},
      .scale = scale,
      .zoom_x = 1,
      .zoom_y = 1,
      .subtitle = how};
}

cv::Mat MomentPictures::ComparisonFigure() const {
  const int blur = setup_.compare_blur;
  std::vector<cv::Mat> panels;
  for (VirtualObject object : {VirtualObject::kPlane, VirtualObject::kSphere}) {
    for (OcclusionTest test : kOcclusionTests) {
      ImageFigure figure = CompositeFigure(object, test, blur);
      figure.title = absl::StrCat(object == VirtualObject::kPlane ? "plane" : "sphere", ": ",
                                  OcclusionTestName(test));
      figure.subtitle.clear();
      figure.legend.clear();
      panels.push_back(RenderImageFigure(figure));
    }
  }
  return RenderGrid(
      panels, static_cast<int>(kOcclusionTests.size()),
      "virtual objects occluded by the real scene: hard depth test, VSM, Hamburger and "
      "Hausdorff 4MSM",
      absl::StrCat(Subtitle(blur),
                   absl::StrFormat("; %dx upscale, bilinear (hard test: nearest texel, no "
                                   "filter); grey: real scene amplitude c0",
                                   setup_.upscale)));
}

cv::Mat MomentPictures::ShadowFigure(int blur) const {
  std::vector<cv::Mat> panels;
  for (OcclusionTest test : kOcclusionTests) {
    ImageFigure figure = BackdropFigure(test, blur);
    figure.title = OcclusionTestName(test);
    figure.subtitle.clear();
    panels.push_back(RenderImageFigure(figure));
  }
  return RenderGrid(
      panels, static_cast<int>(kOcclusionTests.size()),
      absl::StrFormat("virtual light at the camera: soft shadow of the real scene on a backdrop "
                      "(Z %.3g..%.3g m) seen from %.2g m to the camera's right",
                      setup_.backdrop.left_depth_m, setup_.backdrop.right_depth_m,
                      setup_.viewpoint_offset_m),
      absl::StrCat(Subtitle(blur),
                   "; hard test: nearest texel, no filter; grey: no backdrop or "
                   "outside the camera's view"));
}

cv::Mat MomentPictures::VideoFrameFigure() const {
  std::vector<cv::Mat> panels;
  for (OcclusionTest test : {OcclusionTest::kHardDepth, OcclusionTest::kHamburger4}) {
    ImageFigure figure = CompositeFigure(VirtualObject::kPlane, test, setup_.compare_blur);
    figure.title = OcclusionTestName(test);
    figure.subtitle.clear();
    figure.legend.clear();
    panels.push_back(RenderImageFigure(figure));
  }
  return RenderGrid(panels, 2,
                    "virtual plane occluded by the real scene: hard depth test vs Hamburger 4MSM",
                    Subtitle(setup_.compare_blur));
}

absl::StatusOr<int> MomentPictures::WriteFrame(const std::filesystem::path& dir) const {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) {
    return absl::PermissionDeniedError(
        absl::StrCat(dir.string(), ": cannot create the directory (", error.message(), ")"));
  }
  int written = 0;
  const auto png = [&](const std::string& name, const cv::Mat& figure) {
    ++written;
    return WriteFigurePng((dir / name).string(), figure);
  };
  if (absl::Status status = png("map_unfiltered.png", RenderImageFigure(MapFigure(-1)));
      !status.ok()) {
    return status;
  }
  for (int b = 0; b < static_cast<int>(setup_.blur_px.size()); ++b) {
    const std::string sigma = absl::StrCat("sigma_", SigmaText(setup_.blur_px[b]), ".png");
    const std::pair<std::string, cv::Mat> figures[] = {
        {absl::StrCat("map_", sigma), RenderImageFigure(MapFigure(b))},
        {absl::StrCat("plane_", sigma),
         RenderImageFigure(CompositeFigure(VirtualObject::kPlane, OcclusionTest::kHamburger4, b))},
        {absl::StrCat("sphere_", sigma),
         RenderImageFigure(CompositeFigure(VirtualObject::kSphere, OcclusionTest::kHamburger4, b))},
        {absl::StrCat("shadow_", sigma), ShadowFigure(b)},
    };
    for (const auto& [name, figure] : figures) {
      if (absl::Status status = png(name, figure); !status.ok()) return status;
    }
    if (b == setup_.compare_blur) {
      if (absl::Status status = png(absl::StrCat("compare_", sigma), ComparisonFigure());
          !status.ok()) {
        return status;
      }
    }
  }
  return written;
}

}  // namespace transient::tools
