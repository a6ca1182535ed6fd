// Moment-depth pictures: virtual objects and a virtual backdrop tested against the camera's depth
// through filtered moment maps (thesis ch. 4), drawn as labelled figures.
#include "tools/transient/view/moment_pictures.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <system_error>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "transient/reconstruct/smoothing.h"

namespace transient::tools {
namespace {


constexpr Rgb8 kBackgroundSwatch = {150, 150, 150};

// The 64-bit map of thesis §4.1.4 is the one the daemon streams; its decoded texels take the
// bias of eq. 4.4's adapted b* (kQuantized16MomentBias).
constexpr MomentMapFormat kFormat = MomentMapFormat::kOptimized64;

std::string SigmaText(double sigma_px) { return absl::StrFormat("%g", sigma_px); }

// The four texels around (x, y) in pixels (edges clamped) as (row-major index, weight): the
// taps of a bilinear fetch.
using BilinearTaps = std::array<std::pair<size_t, float>, 4>;
BilinearTaps BilinearTapsAt(ImageGeometry g, float x, float y) {
  const float fx = std::floor(x), fy = std::floor(y);
  const float wx = x - fx, wy = y - fy;
  const int x0 = std::clamp(static_cast<int>(fx), 0, g.width - 1);
  const int x1 = std::clamp(static_cast<int>(fx) + 1, 0, g.width - 1);
  const int y0 = std::clamp(static_cast<int>(fy), 0, g.height - 1);
  const int y1 = std::clamp(static_cast<int>(fy) + 1, 0, g.height - 1);
  return {{
      {static_cast<size_t>(y0) * g.width + x0, (1 - wx) * (1 - wy)},
      {static_cast<size_t>(y0) * g.width + x1, wx * (1 - wy)},
      {static_cast<size_t>(y1) * g.width + x0, (1 - wx) * wy},
      {static_cast<size_t>(y1) * g.width + x1, wx * wy},
  }};
}

float Bilinear(std::span<const float> plane, ImageGeometry g, float x, float y) {
  float value = 0.0f;
  for (const auto& [p, w] : BilinearTapsAt(g, x, y)) value += w * plane[p];
  return value;
}

}  // namespace

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
        std::isfinite(c0[p]) ? std::clamp(static_cast<float>(c0[p] / scale), 0.0f, 1.0f) : kNaNf;
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
  std::vector<float> visibility(static_cast<size_t>(n), kNaNf);
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
    PowerMomentsF b = {1.0f, 0.0f, 0.0f, 0.0f, 0.0f};
    for (const auto& [p, w] : BilinearTapsAt(g, x, y)) {
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
