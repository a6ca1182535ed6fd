// Labelled raster figures drawn with OpenCV: a data image at an integer zoom with axes, ticks,
// a title and a colour bar or a categorical legend, and the drawing helpers that the per-pixel
// plot shares. Figures are 8-bit RGB (channel 0 is red), white background, even width and
// height so that H.264 (4:2:0) video takes them as they are.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>  // the Hershey fonts

#include "absl/status/status.h"
#include "tools/transient/common/image_writers.h"
#include "transient/reconstruct/image.h"

namespace transient::tools {

// A linear axis along one side of the data image: `begin` is the value at the image's leading
// edge (left, or top for a vertical axis), `end` at its trailing edge. Pixel axes of an image of
// width W run from -0.5 to W - 0.5, so that tick i sits at the centre of pixel i.
struct Axis {
  std::string label;  // with its unit: "x [px]", "time of flight tau [ns]"
  double begin = 0.0;
  double end = 1.0;
};

// Colours of a continuous quantity: ColourMap (inferno) over [min, max]; NaN is kNoValueGrey.
struct ColourScale {
  std::string label;  // with its unit: "density D [sensor units/rad]"
  double min = 0.0;
  double max = 1.0;   // > min

  Rgb8 Colour(float value) const;
  // ColourMap of a whole plane, three bytes per value.
  std::vector<uint8_t> Colours(const std::vector<float>& values) const;
};

struct LegendEntry {
  Rgb8 colour;
  std::string text;
};

// A data image with its axes and either a colour bar (scale) or a legend (or neither).
struct ImageFigure {
  std::string title;
  ImageGeometry geometry;     // of the data image
  std::vector<uint8_t> rgb;   // geometry.pixel_count() * 3 bytes
  Axis x;
  Axis y;
  std::optional<ColourScale> scale = std::nullopt;
  std::vector<LegendEntry> legend = {};
  // Data pixels drawn `zoom_x` by `zoom_y` screen pixels (nearest neighbour); 0 = automatic:
  // the smallest integer that makes the image at least kTargetImageSize wide or high.
  int zoom_x = 0;
  int zoom_y = 0;
  // A second, smaller line under the title (what the picture shows in detail); empty: none.
  std::string subtitle = {};
};

inline constexpr int kTargetImageSize = 480;

// Draws the figure. Deterministic: the same figure gives the same pixels.
cv::Mat RenderImageFigure(const ImageFigure& figure);
// Where RenderImageFigure draws the data image: data pixel (x, y) covers the screen pixels
// from (area.x + x * zoom_x, area.y + y * zoom_y) on, zoom = area size / geometry.
cv::Rect DataArea(const ImageFigure& figure);

// Rendered figures (e.g. RenderImageFigure's) side by side, `columns` per row, each in a cell of
// the largest panel's size (smaller panels centred), under a title and an optional subtitle.
// White background, even width and height, deterministic.
cv::Mat RenderGrid(const std::vector<cv::Mat>& panels, int columns, const std::string& title,
                   const std::string& subtitle = "");

// Writes an 8-bit RGB figure as PNG (WritePngRgb8: a failed write leaves no file).
absl::Status WriteFigurePng(const std::string& path, const cv::Mat& rgb);

// --- Helpers shared with the plots ---

// About `target` tick values at multiples of 1, 2 or 5 times a power of ten within [lo, hi].
std::vector<double> NiceTicks(double lo, double hi, int target = 6);
// A tick label with the decimals the tick step needs ("0.5", "12", "1e+03" never).
std::string FormatTick(double value, double step);
// A value for a title or legend with `digits` significant digits ("0.0123", "1.2e+05").
std::string FormatValue(double value, int digits = 3);

inline const cv::Scalar kBlack(0, 0, 0);
inline const cv::Scalar kWhite(255, 255, 255);
inline constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
inline constexpr double kFontScale = 0.45;
inline constexpr double kTitleScale = 0.55;

cv::Scalar ToScalar(Rgb8 colour);
// Text with its baseline-left corner at `origin`; `anchor_x` 0 = left, 0.5 = centre, 1 = right.
void DrawText(cv::Mat& canvas, const std::string& text, cv::Point origin, double anchor_x = 0.0,
              double scale = kFontScale, cv::Scalar colour = kBlack);
// Text rotated 90 degrees counter-clockwise (reading upwards), centred on `centre`.
void DrawVerticalText(cv::Mat& canvas, const std::string& text, cv::Point centre,
                      double scale = kFontScale);
int TextWidth(const std::string& text, double scale = kFontScale);

}  // namespace transient::tools
