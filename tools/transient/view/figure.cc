// Layout and drawing of labelled raster figures with OpenCV (Hershey fonts, no font files).
#include "tools/transient/view/figure.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <span>

#include <opencv2/imgproc.hpp>

#include "absl/strings/str_format.h"

namespace transient::tools {
namespace {

constexpr int kTickLength = 5;
constexpr int kGap = 6;
constexpr int kOuterMargin = 12;
constexpr int kColourBarWidth = 18;
constexpr int kSwatch = 14;

int TextHeight(double scale) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize("Ag", kFont, scale, 1, &baseline);
  return size.height + baseline;
}

// Screen position of `value` on an axis drawn from `origin` over `length` pixels.
double Position(const Axis& axis, double value, int origin, int length) {
  return origin + (value - axis.begin) / (axis.end - axis.begin) * length;
}

double TickStep(const std::vector<double>& ticks) {
  return ticks.size() >= 2 ? ticks[1] - ticks[0] : 1.0;
}

std::vector<std::string> TickLabels(const std::vector<double>& ticks) {
  std::vector<std::string> labels;
  for (double tick : ticks) labels.push_back(FormatTick(tick, TickStep(ticks)));
  return labels;
}

int MaxWidth(const std::vector<std::string>& texts) {
  int width = 0;
  for (const std::string& text : texts) width = std::max(width, TextWidth(text));
  return width;
}

// A title line that never widens the figure (a video's frames must keep one size): a long one
// is drawn smaller, centred on `centre_x` or, when it does not fit there, on the canvas.
void DrawHeading(cv::Mat& canvas, const std::string& text, double scale, int centre_x,
                 int baseline_y) {
  while (scale > 0.3 && TextWidth(text, scale) > canvas.cols - 2 * kGap) scale *= 0.95;
  const int width = TextWidth(text, scale);
  centre_x = std::clamp(centre_x, kGap + width / 2,
                        std::max(kGap + width / 2, canvas.cols - kGap - width / 2));
  DrawText(canvas, text, cv::Point(centre_x, baseline_y), 0.5, scale);
}

}  // namespace

Rgb8 ColourScale::Colour(float value) const {
  assert(max > min);
  if (std::isnan(value)) return kNoValueGrey;
  return ColourMap(static_cast<float>(value - min), static_cast<float>(max - min));
}

std::vector<uint8_t> ColourScale::Colours(const std::vector<float>& values) const {
  std::vector<uint8_t> rgb(values.size() * 3);
  for (size_t i = 0; i < values.size(); ++i) {
    const Rgb8 colour = Colour(values[i]);
    rgb[3 * i] = colour.r;
    rgb[3 * i + 1] = colour.g;
    rgb[3 * i + 2] = colour.b;
  }
  return rgb;
}

std::vector<double> NiceTicks(double lo, double hi, int target) {
  std::vector<double> ticks;
  if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi)) return ticks;
  const double raw = (hi - lo) / std::max(target, 1);
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  double step = power;
  for (double multiple : {1.0, 2.0, 5.0, 10.0}) {
    step = multiple * power;
    if (step >= raw) break;
  }
  // A tick within a millionth of a step of the edge still counts as inside.
  const double slack = 1e-6 * step;
  for (double k = std::ceil((lo - slack) / step); k * step <= hi + slack; k += 1.0) {
    const double tick = k * step;
    ticks.push_back(std::abs(tick) < slack ? 0.0 : tick);
  }
  return ticks;
}

std::string FormatTick(double value, double step) {
  const int decimals = step > 0.0 ? std::max(0, static_cast<int>(-std::floor(std::log10(step) +
                                                                             1e-9)))
                                  : 0;
  return absl::StrFormat("%.*f", decimals, value);
}

std::string FormatValue(double value, int digits) {
  if (std::isnan(value)) return "NaN";
  return absl::StrFormat("%.*g", digits, value);
}

cv::Scalar ToScalar(Rgb8 colour) { return cv::Scalar(colour.r, colour.g, colour.b); }

int TextWidth(const std::string& text, double scale) {
  int baseline = 0;
  return cv::getTextSize(text, kFont, scale, 1, &baseline).width;
}

void DrawText(cv::Mat& canvas, const std::string& text, cv::Point origin, double anchor_x,
              double scale, cv::Scalar colour) {
  const int width = TextWidth(text, scale);
  origin.x -= static_cast<int>(std::lround(anchor_x * width));
  cv::putText(canvas, text, origin, kFont, scale, colour, 1, cv::LINE_AA);
}

void DrawVerticalText(cv::Mat& canvas, const std::string& text, cv::Point centre, double scale) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFont, scale, 1, &baseline);
  cv::Mat strip(size.height + baseline + 4, size.width + 4, canvas.type(), kWhite);
  cv::putText(strip, text, cv::Point(2, size.height + 2), kFont, scale, kBlack, 1, cv::LINE_AA);
  cv::Mat rotated;
  cv::rotate(strip, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
  cv::Rect target(centre.x - rotated.cols / 2, centre.y - rotated.rows / 2, rotated.cols,
                  rotated.rows);
  const cv::Rect clipped = target & cv::Rect(0, 0, canvas.cols, canvas.rows);
  if (clipped.area() == 0) return;
  rotated(cv::Rect(clipped.x - target.x, clipped.y - target.y, clipped.width, clipped.height))
      .copyTo(canvas(clipped));
}

cv::Rect DataArea(const ImageFigure& figure) {
  const int width = figure.geometry.width, height = figure.geometry.height;
  const int automatic =
      std::max(1, (kTargetImageSize + std::max(width, height) - 1) / std::max(width, height));
  const int zoom_x = figure.zoom_x > 0 ? figure.zoom_x : automatic;
  const int zoom_y = figure.zoom_y > 0 ? figure.zoom_y : automatic;
  const int image_width = width * zoom_x, image_height = height * zoom_y;
  const std::vector<double> y_ticks =
      NiceTicks(std::min(figure.y.begin, figure.y.end), std::max(figure.y.begin, figure.y.end),
                std::max(2, image_height / 60));
  const int text_height = TextHeight(kFontScale);
  const int left =
      kOuterMargin + text_height + kGap + MaxWidth(TickLabels(y_ticks)) + kGap + kTickLength;
  int top = kOuterMargin + TextHeight(kTitleScale) + 2 * kGap;
  if (!figure.subtitle.empty()) top += TextHeight(kFontScale) + kGap;
  return cv::Rect(left, top, image_width, image_height);
}

cv::Mat RenderImageFigure(const ImageFigure& figure) {
  const int width = figure.geometry.width, height = figure.geometry.height;
  assert(width > 0 && height > 0);
  assert(static_cast<int64_t>(figure.rgb.size()) == figure.geometry.pixel_count() * 3);
  const cv::Rect area = DataArea(figure);
  const int image_width = area.width, image_height = area.height;

  const std::vector<double> x_ticks =
      NiceTicks(std::min(figure.x.begin, figure.x.end), std::max(figure.x.begin, figure.x.end),
                std::max(2, image_width / 80));
  const std::vector<double> y_ticks =
      NiceTicks(std::min(figure.y.begin, figure.y.end), std::max(figure.y.begin, figure.y.end),
                std::max(2, image_height / 60));
  const std::vector<std::string> x_labels = TickLabels(x_ticks);
  const std::vector<std::string> y_labels = TickLabels(y_ticks);
  const int text_height = TextHeight(kFontScale);

  std::vector<double> bar_ticks;
  std::vector<std::string> bar_labels;
  if (figure.scale.has_value()) {
    bar_ticks = NiceTicks(figure.scale->min, figure.scale->max, std::max(2, image_height / 60));
    bar_labels = TickLabels(bar_ticks);
  }
  std::vector<std::string> legend_texts;
  for (const LegendEntry& entry : figure.legend) legend_texts.push_back(entry.text);

  const int left = area.x;
  const int top = area.y;
  const int bottom = kTickLength + kGap + text_height + kGap + text_height + kOuterMargin;
  int right = kOuterMargin;
  if (figure.scale.has_value()) {
    right += 2 * kGap + kColourBarWidth + kTickLength + kGap + MaxWidth(bar_labels) + kGap +
             text_height;
  }
  const int legend_row = kSwatch + 6;
  if (!figure.legend.empty()) right += 2 * kGap + kSwatch + kGap + MaxWidth(legend_texts);
  int canvas_width = left + image_width + right;
  int canvas_height = top + image_height + bottom;
  canvas_height = std::max(canvas_height, top + static_cast<int>(figure.legend.size()) * legend_row +
                                              kOuterMargin);
  canvas_width += canvas_width % 2;  // H.264 with 4:2:0 chroma wants even sizes
  canvas_height += canvas_height % 2;
  cv::Mat canvas(canvas_height, canvas_width, CV_8UC3, kWhite);

  // The data image, nearest-neighbour zoomed.
  cv::Mat data(height, width, CV_8UC3, const_cast<uint8_t*>(figure.rgb.data()));
  cv::Mat zoomed;
  cv::resize(data, zoomed, cv::Size(image_width, image_height), 0, 0, cv::INTER_NEAREST);
  zoomed.copyTo(canvas(cv::Rect(left, top, image_width, image_height)));
  cv::rectangle(canvas, cv::Rect(left - 1, top - 1, image_width + 2, image_height + 2), kBlack);

  DrawHeading(canvas, figure.title, kTitleScale, left + image_width / 2,
              kOuterMargin + TextHeight(kTitleScale));
  if (!figure.subtitle.empty()) {
    DrawHeading(canvas, figure.subtitle, kFontScale, left + image_width / 2,
                kOuterMargin + TextHeight(kTitleScale) + kGap + TextHeight(kFontScale));
  }
  for (size_t i = 0; i < x_ticks.size(); ++i) {
    const int x = static_cast<int>(std::lround(Position(figure.x, x_ticks[i], left, image_width)));
    const int y = top + image_height;
    cv::line(canvas, cv::Point(x, y), cv::Point(x, y + kTickLength), kBlack);
    DrawText(canvas, x_labels[i], cv::Point(x, y + kTickLength + kGap + text_height - 4), 0.5);
  }
  DrawText(canvas, figure.x.label,
           cv::Point(left + image_width / 2,
                     top + image_height + kTickLength + 2 * kGap + 2 * text_height - 4),
           0.5);
  for (size_t i = 0; i < y_ticks.size(); ++i) {
    const int y = static_cast<int>(std::lround(Position(figure.y, y_ticks[i], top, image_height)));
    cv::line(canvas, cv::Point(left - kTickLength, y), cv::Point(left, y), kBlack);
    DrawText(canvas, y_labels[i], cv::Point(left - kTickLength - kGap, y + text_height / 2 - 2),
             1.0);
  }
  DrawVerticalText(canvas, figure.y.label,
                   cv::Point(kOuterMargin + text_height / 2, top + image_height / 2));

  int x = left + image_width + 2 * kGap;
  if (figure.scale.has_value()) {
    const ColourScale& scale = *figure.scale;
    for (int row = 0; row < image_height; ++row) {
      const double value = scale.max - (row + 0.5) / image_height * (scale.max - scale.min);
      cv::line(canvas, cv::Point(x, top + row), cv::Point(x + kColourBarWidth - 1, top + row),
               ToScalar(scale.Colour(static_cast<float>(value))));
    }
    cv::rectangle(canvas, cv::Rect(x - 1, top - 1, kColourBarWidth + 2, image_height + 2),
                  kBlack);
    const int tick_x = x + kColourBarWidth;
    for (size_t i = 0; i < bar_ticks.size(); ++i) {
      const int y = top + static_cast<int>(std::lround((scale.max - bar_ticks[i]) /
                                                       (scale.max - scale.min) * image_height));
      cv::line(canvas, cv::Point(tick_x, y), cv::Point(tick_x + kTickLength, y), kBlack);
      DrawText(canvas, bar_labels[i],
               cv::Point(tick_x + kTickLength + kGap, y + text_height / 2 - 2));
    }
    const int label_x = tick_x + kTickLength + kGap + MaxWidth(bar_labels) + kGap + text_height / 2;
    DrawVerticalText(canvas, scale.label, cv::Point(label_x, top + image_height / 2));
    x = label_x + text_height / 2 + 2 * kGap;
  }
  for (size_t i = 0; i < figure.legend.size(); ++i) {
    const int y = top + static_cast<int>(i) * legend_row;
    cv::rectangle(canvas, cv::Rect(x, y, kSwatch, kSwatch), ToScalar(figure.legend[i].colour),
                  cv::FILLED);
    cv::rectangle(canvas, cv::Rect(x, y, kSwatch, kSwatch), kBlack);
    DrawText(canvas, figure.legend[i].text, cv::Point(x + kSwatch + kGap, y + kSwatch - 2));
  }
  return canvas;
}

cv::Mat RenderGrid(const std::vector<cv::Mat>& panels, int columns, const std::string& title,
                   const std::string& subtitle) {
  assert(!panels.empty() && columns >= 1);
  int cell_width = 0, cell_height = 0;
  for (const cv::Mat& panel : panels) {
    assert(panel.type() == CV_8UC3);
    cell_width = std::max(cell_width, panel.cols);
    cell_height = std::max(cell_height, panel.rows);
  }
  columns = std::min<int>(columns, static_cast<int>(panels.size()));
  const int rows = (static_cast<int>(panels.size()) + columns - 1) / columns;
  int top = kOuterMargin + TextHeight(kTitleScale) + kGap;
  if (!subtitle.empty()) top += TextHeight(kFontScale) + kGap;
  int width = columns * cell_width, height = top + rows * cell_height;
  width += width % 2;
  height += height % 2;
  cv::Mat canvas(height, width, CV_8UC3, kWhite);
  DrawHeading(canvas, title, kTitleScale, width / 2, kOuterMargin + TextHeight(kTitleScale));
  if (!subtitle.empty()) {
    DrawHeading(canvas, subtitle, kFontScale, width / 2,
                kOuterMargin + TextHeight(kTitleScale) + kGap + TextHeight(kFontScale));
  }
  for (size_t i = 0; i < panels.size(); ++i) {
    const int column = static_cast<int>(i) % columns, row = static_cast<int>(i) / columns;
    const cv::Mat& panel = panels[i];
    const int x = column * cell_width + (cell_width - panel.cols) / 2;
    const int y = top + row * cell_height + (cell_height - panel.rows) / 2;
    panel.copyTo(canvas(cv::Rect(x, y, panel.cols, panel.rows)));
  }
  return canvas;
}

absl::Status WriteFigurePng(const std::string& path, const cv::Mat& rgb) {
  assert(rgb.type() == CV_8UC3 && rgb.isContinuous());
  return WritePngRgb8(path, ImageGeometry{.width = rgb.cols, .height = rgb.rows},
                      std::span<const uint8_t>(rgb.data, rgb.total() * 3));
}

}  // namespace transient::tools
