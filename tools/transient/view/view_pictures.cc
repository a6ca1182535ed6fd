// Colour-mapped, labelled images of one transient frame.
#include "tools/transient/view/view_pictures.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "transient/reconstruct/percentile.h"

namespace transient::tools {
namespace {

Axis PixelAxisX(const TransientFrame& frame) {
  return {.label = "x [px]", .begin = -0.5, .end = frame.geometry.width - 0.5};
}
Axis PixelAxisY(const TransientFrame& frame) {
  return {.label = "y [px]", .begin = -0.5, .end = frame.geometry.height - 0.5};
}

std::span<const float> Plane(const std::vector<float>& planes, int plane, int64_t pixels) {
  assert(static_cast<int64_t>(planes.size()) >= (plane + 1) * pixels);
  return std::span<const float>(planes).subspan(plane * pixels, pixels);
}

ImageFigure ScaledImage(const TransientFrame& frame, std::span<const float> values,
                        std::string title, ColourScale scale) {
  const std::vector<float> copy(values.begin(), values.end());
  return {.title = std::move(title),
          .geometry = frame.geometry,
          .rgb = scale.Colours(copy),
          .x = PixelAxisX(frame),
          .y = PixelAxisY(frame),
          .scale = std::move(scale)};
}

std::string TauText(const TransientFrame& frame, int bin) {
  const double tau_ns = frame.BinTimeOfFlightNs(bin);
  return absl::StrFormat("tau = %.2f ns (range %.2f m), bin %d/%d", tau_ns,
                         RangeOfTimeOfFlightNs(tau_ns), bin, frame.bins());
}

constexpr std::array<FlagCategory, 8> kFlagCategories = {{
    {kFlagSaturated, "saturated (8)", {213, 94, 0}},
    {kFlagInvalidInput, "invalid input (2)", {0, 0, 0}},
    {kFlagNoReturn, "no return (4)", {230, 159, 0}},
    {kFlagAmbiguous, "ambiguous (32)", {204, 121, 167}},
    {kFlagLowAmplitude, "low amplitude (64)", {0, 114, 178}},
    {kFlagOutlierFilled, "outlier-filled (16)", {0, 158, 115}},
    {kFlagBiased, "biased (1)", {86, 180, 233}},
    {0, "no flag", {235, 235, 235}},
}};

}  // namespace

double Quantile(std::vector<float>& samples, double q) {
  const auto end = std::remove_if(samples.begin(), samples.end(),
                                  [](float v) { return !std::isfinite(v); });
  samples.erase(end, samples.end());
  return Percentile(std::span<float>(samples), 100.0 * q);
}

void ScaleSampler::Add(std::span<const float> values) {
  // The first value taken from this call continues the stride of the previous calls.
  int64_t first = (stride_ - position_ % stride_) % stride_;
  for (int64_t i = first; i < static_cast<int64_t>(values.size()); i += stride_) {
    if (std::isfinite(values[i])) samples_.push_back(values[i]);
  }
  position_ += static_cast<int64_t>(values.size());
}

double ScaleSampler::Quantile(double q, double fallback) {
  const double value = transient::tools::Quantile(samples_, q);
  return std::isnan(value) ? fallback : value;
}

double PositiveScale(double quantile) {
  return std::isfinite(quantile) && quantile > 0.0 ? quantile : 1.0;
}

ImageFigure SliceFigure(const TransientFrame& frame, int bin, double scale) {
  assert(bin >= 0 && bin < frame.bins());
  return ScaledImage(frame, Plane(frame.density, bin, frame.geometry.pixel_count()),
                     absl::StrCat("MESE density, frame ", frame.index, ", ", TauText(frame, bin)),
                     {.label = absl::StrCat("density D [", kDensityUnit, "]"),
                      .min = 0.0,
                      .max = scale});
}

ImageFigure CumulativeFigure(const TransientFrame& frame, int bin, double scale) {
  assert(bin >= 0 && bin < frame.bins());
  return ScaledImage(
      frame, Plane(frame.cumulative, bin, frame.geometry.pixel_count()),
      absl::StrCat("cumulative light, frame ", frame.index, ", ",
                   TauText(frame, bin)),
      {.label = absl::StrCat("cumulative F [", kLightUnit, "]"), .min = 0.0, .max = scale});
}

std::vector<float> StreakPlane(const TransientFrame& frame, int y) {
  const int width = frame.geometry.width;
  assert(y >= 0 && y < frame.geometry.height);
  std::vector<float> streak(static_cast<size_t>(frame.bins()) * width);
  for (int n = 0; n < frame.bins(); ++n) {
    for (int x = 0; x < width; ++x) streak[n * width + x] = frame.at(frame.density, n, x, y);
  }
  return streak;
}

ImageFigure StreakFigure(const TransientFrame& frame, int y, double scale) {
  const int bins = frame.bins();
  const double first = frame.BinTimeOfFlightNs(0);
  const double step = bins > 1 ? (frame.BinTimeOfFlightNs(bins - 1) - first) / (bins - 1)
                               : frame.period_s() * 1e9;
  const ColourScale colours{
      .label = absl::StrCat("density D [", kDensityUnit, "]"), .min = 0.0, .max = scale};
  ImageFigure figure{
      .title = absl::StrCat("streak image of scanline y = ", y, ", frame ", frame.index),
      .geometry = {.width = frame.geometry.width, .height = bins},
      .rgb = colours.Colours(StreakPlane(frame, y)),
      .x = PixelAxisX(frame),
      .y = {.label = "time of flight tau [ns]",
            .begin = first - step / 2,
            .end = first + (bins - 0.5) * step},
      .scale = colours,
  };
  const int zoom = std::max(1, (kTargetImageSize + frame.geometry.width - 1) / frame.geometry.width);
  figure.zoom_x = zoom;
  figure.zoom_y = std::max(1, (kTargetImageSize * 3 / 4 + bins / 2) / bins);
  return figure;
}

ImageFigure RangeFigure(const TransientFrame& frame, const ViewScales& scales, bool pisarenko) {
  const std::vector<float>& range = pisarenko ? frame.pisarenko_range_m : frame.range_m;
  ImageFigure figure = ScaledImage(
      frame, range,
      absl::StrCat(pisarenko ? "range of the first Pisarenko return" : "range of the first return",
                   ", frame ", frame.index, " (grey: none)"),
      {.label = "range c*tau/2 [m]", .min = scales.range_min_m, .max = scales.range_max_m});
  return figure;
}

ImageFigure AmplitudeFigure(const TransientFrame& frame, double scale) {
  return ScaledImage(frame, frame.c0,
                     absl::StrCat("amplitude c0 (all light), frame ", frame.index),
                     {.label = absl::StrCat("c0 [", kLightUnit, "]"), .min = 0.0, .max = scale});
}

ImageFigure DirectFigure(const TransientFrame& frame, double scale) {
  return ScaledImage(
      frame, frame.pisarenko_direct,
      absl::StrCat("direct light (first Pisarenko return), frame ", frame.index),
      {.label = absl::StrCat("weight [", kLightUnit, "]"), .min = 0.0, .max = scale});
}

ImageFigure IndirectFigure(const TransientFrame& frame, double scale) {
  return ScaledImage(
      frame, frame.pisarenko_indirect,
      absl::StrCat("indirect light (later Pisarenko returns), frame ", frame.index),
      {.label = absl::StrCat("weight [", kLightUnit, "]"), .min = 0.0, .max = scale});
}

std::span<const FlagCategory> FlagCategories() { return kFlagCategories; }

Rgb8 FlagColour(uint8_t flags) {
  for (const FlagCategory& category : kFlagCategories) {
    if (category.bit == 0 || (flags & category.bit) != 0) return category.colour;
  }
  return kFlagCategories.back().colour;
}

ImageFigure FlagsFigure(const TransientFrame& frame) {
  const int64_t pixels = frame.geometry.pixel_count();
  std::vector<uint8_t> rgb(pixels * 3);
  for (int64_t p = 0; p < pixels; ++p) {
    const Rgb8 colour = FlagColour(frame.flags[p]);
    rgb[3 * p] = colour.r;
    rgb[3 * p + 1] = colour.g;
    rgb[3 * p + 2] = colour.b;
  }
  std::vector<LegendEntry> legend;
  for (const FlagCategory& category : kFlagCategories) {
    const int64_t count =
        std::count_if(frame.flags.begin(), frame.flags.end(), [&](uint8_t flags) {
          return category.bit == 0 ? flags == 0 : (flags & category.bit) != 0;
        });
    legend.push_back({category.colour,
                      absl::StrFormat("%s: %.1f%%", category.name, 100.0 * count / pixels)});
  }
  return {.title = absl::StrCat("flags (first bit in legend order), frame ", frame.index),
          .geometry = frame.geometry,
          .rgb = std::move(rgb),
          .x = PixelAxisX(frame),
          .y = PixelAxisY(frame),
          .legend = std::move(legend)};
}

}  // namespace transient::tools
