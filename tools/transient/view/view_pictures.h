// The image pictures of `transient view` (thesis §8.5): transient slices (fig. 8.8, 8.15),
// cumulative frames (fig. 8.10), streak images (fig. 8.9), range, amplitude, flags and the
// direct/indirect separation (fig. 8.16), each as a labelled figure built from a
// TransientFrame, whatever its source. Colour scales are passed in so that a whole run shares
// them (ViewScales, chosen once over everything drawn).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "tools/transient/view/figure.h"
#include "transient/formats/transient_frame.h"

namespace transient::tools {

inline constexpr char kDensityUnit[] = "sensor units/rad";  // units::kSensorPerRadian, spelt out
inline constexpr char kLightUnit[] = "sensor units";         // units::kSensor, spelt out

// Upper ends (and for range both ends) of the colour scales of a run; each is > its lower end.
struct ViewScales {
  double density = 1.0;          // density, slices and streak images: [0, density]
  double cumulative = 1.0;       // cumulative frames: [0, cumulative]
  double amplitude = 1.0;        // c_0: [0, amplitude]
  double direct_indirect = 1.0;  // direct and indirect images share [0, direct_indirect]
  double range_min_m = 0.0;      // range: [range_min_m, range_max_m]
  double range_max_m = 1.0;
};

// The q-quantile (0 <= q <= 1) of the finite values among `samples` (reordered): the
// project's percentile (percentile.h) at 100 q; NaN when there is none.
double Quantile(std::vector<float>& samples, double q);

// Collects every stride-th finite value (a deterministic subsample, so that scales over
// thousands of planes need bounded memory) for Quantile.
class ScaleSampler {
 public:
  explicit ScaleSampler(int64_t stride = 1) : stride_(stride < 1 ? 1 : stride) {}
  void Add(std::span<const float> values);
  // Quantile q of what was added; `fallback` when nothing finite was added.
  double Quantile(double q, double fallback);
  int64_t size() const { return static_cast<int64_t>(samples_.size()); }

 private:
  int64_t stride_;
  int64_t position_ = 0;  // values seen, across calls, for the stride
  std::vector<float> samples_;
};

// A scale's upper end from a quantile: positive and finite (1 when the data give none).
double PositiveScale(double quantile);

// Density D(phi_bin) of every pixel (thesis eq. 8.3). Needs frame.density.
ImageFigure SliceFigure(const TransientFrame& frame, int bin, double scale);
// Cumulative F(phi_bin), the light arrived until tau (thesis eq. 8.9). Needs frame.cumulative.
ImageFigure CumulativeFigure(const TransientFrame& frame, int bin, double scale);

// Density of scanline y over all bins: value [bin * width + x] = D_(x, y)(phi_bin); one row per
// bin (time of flight downwards), one column per pixel of the scanline.
std::vector<float> StreakPlane(const TransientFrame& frame, int y);
// The streak image of scanline y (thesis fig. 8.9): pixel column x across, tau down.
ImageFigure StreakFigure(const TransientFrame& frame, int y, double scale);

// Range of the first return in metres over [scales.range_min_m, range_max_m]. `pisarenko`
// draws /pisarenko/range_m instead of /range_m.
ImageFigure RangeFigure(const TransientFrame& frame, const ViewScales& scales,
                        bool pisarenko = false);
// c_0 after biasing (all light of the pixel, thesis fig. 8.16a).
ImageFigure AmplitudeFigure(const TransientFrame& frame, double scale);
// Direct (first Pisarenko return) or indirect (the other returns) light (thesis §8.4.1).
ImageFigure DirectFigure(const TransientFrame& frame, double scale);
ImageFigure IndirectFigure(const TransientFrame& frame, double scale);

// The PixelFlag bits as categories: a pixel takes the colour of its first bit in the order
// saturated, invalid input, no return, ambiguous, low amplitude, outlier-filled, biased; the
// legend gives each bit's share of all pixels.
struct FlagCategory {
  uint8_t bit;  // 0 for "no flag"
  const char* name;
  Rgb8 colour;
};
std::span<const FlagCategory> FlagCategories();
Rgb8 FlagColour(uint8_t flags);
ImageFigure FlagsFigure(const TransientFrame& frame);

}  // namespace transient::tools
