// Line plots of one pixel's reconstruction drawn with OpenCV.
#include "tools/transient/view/pixel_plot.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "tools/transient/view/figure.h"
#include "tools/transient/view/view_pictures.h"

namespace transient::tools {
namespace {

constexpr int kLeft = 90;
constexpr int kRight = 110;
constexpr int kTop = 78;
constexpr int kDensityHeight = 250;
constexpr int kPanelGap = 22;
constexpr int kCumulativeHeight = 170;
constexpr int kPlotWidth = kPixelPlotWidth - kLeft - kRight;

const cv::Scalar kDensityColour(0, 114, 178);
const cv::Scalar kBandColour(190, 215, 238);
const cv::Scalar kBandEdgeColour(110, 160, 205);
const cv::Scalar kPisarenkoColour(213, 94, 0);
const cv::Scalar kUniformColour(110, 110, 110);
const cv::Scalar kGridColour(225, 225, 225);

// A panel: a rectangle of the canvas with a value range on its vertical axis.
struct Panel {
  cv::Rect area;
  double max = 1.0;  // the axis runs from 0 at the bottom to max at the top
  double tau_max_ns = 1.0;

  int X(double tau_ns) const {
    return area.x + static_cast<int>(std::lround(tau_ns / tau_max_ns * area.width));
  }
  int Y(double value, double axis_max) const {
    const double clamped = std::clamp(value / axis_max, 0.0, 1.0);
    return area.y + area.height - static_cast<int>(std::lround(clamped * area.height));
  }
  int Y(double value) const { return Y(value, max); }
};

double AxisMax(double largest) {
  return std::isfinite(largest) && largest > 0.0 ? largest * 1.08 : 1.0;
}

void DashedLine(cv::Mat& canvas, cv::Point a, cv::Point b, cv::Scalar colour) {
  const double length = std::hypot(b.x - a.x, b.y - a.y);
  const int dashes = std::max(1, static_cast<int>(length / 8));
  for (int i = 0; i < dashes; i += 2) {
    const double t0 = static_cast<double>(i) / dashes, t1 = static_cast<double>(i + 1) / dashes;
    cv::line(canvas, a + (b - a) * t0, a + (b - a) * t1, colour, 1, cv::LINE_AA);
  }
}

// Ticks and labels of a vertical axis on the left (side = -1) or right (side = +1) of `panel`.
void VerticalAxis(cv::Mat& canvas, const Panel& panel, double axis_max, int side,
                  const std::string& label, bool grid) {
  const std::vector<double> ticks = NiceTicks(0.0, axis_max, std::max(2, panel.area.height / 50));
  const double step = ticks.size() >= 2 ? ticks[1] - ticks[0] : axis_max;
  const int edge = side < 0 ? panel.area.x : panel.area.x + panel.area.width;
  int widest = 0;
  for (double tick : ticks) {
    const int y = panel.Y(tick, axis_max);
    if (grid) {
      cv::line(canvas, cv::Point(panel.area.x, y), cv::Point(panel.area.x + panel.area.width, y),
               kGridColour);
    }
    cv::line(canvas, cv::Point(edge, y), cv::Point(edge + side * 5, y), kBlack);
    const std::string text = FormatTick(tick, step);
    widest = std::max(widest, TextWidth(text));
    DrawText(canvas, text, cv::Point(edge + side * 9, y + 4), side < 0 ? 1.0 : 0.0);
  }
  DrawVerticalText(canvas, label,
                   cv::Point(edge + side * (9 + widest + 14), panel.area.y + panel.area.height / 2));
}

// Ticks of the time axis along the bottom of `panel`, labelled when `labelled`.
void TimeTicks(cv::Mat& canvas, const Panel& panel, bool labelled) {
  const std::vector<double> ticks = NiceTicks(0.0, panel.tau_max_ns, 8);
  const double step = ticks.size() >= 2 ? ticks[1] - ticks[0] : 1.0;
  const int bottom = panel.area.y + panel.area.height;
  for (double tick : ticks) {
    const int x = panel.X(tick);
    cv::line(canvas, cv::Point(x, panel.area.y), cv::Point(x, bottom), kGridColour);
    cv::line(canvas, cv::Point(x, bottom), cv::Point(x, bottom + 5), kBlack);
    if (labelled) DrawText(canvas, FormatTick(tick, step), cv::Point(x, bottom + 20), 0.5);
  }
}

void Polyline(cv::Mat& canvas, const std::vector<cv::Point>& points, cv::Scalar colour,
              int thickness = 1) {
  if (points.size() >= 2) {
    cv::polylines(canvas, points, false, colour, thickness, cv::LINE_AA);
  }
}

std::string FlagNames(uint8_t flags) {
  if (flags == 0) return "none";
  std::string names;
  for (const FlagCategory& category : FlagCategories()) {
    if (category.bit != 0 && (flags & category.bit) != 0) {
      absl::StrAppend(&names, names.empty() ? "" : ", ", category.name);
    }
  }
  return names;
}

}  // namespace

cv::Mat RenderPixelPlot(const TransientFrame& frame, int x, int y) {
  assert(x >= 0 && x < frame.geometry.width && y >= 0 && y < frame.geometry.height);
  cv::Mat canvas(kPixelPlotHeight, kPixelPlotWidth, CV_8UC3, kWhite);
  const int bins = frame.bins();
  const double period_ns = frame.period_s() * 1e9;
  const double two_pi = 2.0 * std::numbers::pi;
  const bool has_density = !frame.density.empty();
  const bool has_cumulative = !frame.cumulative.empty();
  const bool has_bounds = !frame.bounds_lower.empty();
  const bool has_pisarenko = !frame.pisarenko_weight.empty();
  const float c0 = frame.c0.empty() ? std::nanf("") : frame.at(frame.c0, 0, x, y);

  // The samples of the curves: bins phases plus the wrap-around to one period (the density
  // and the bounds are periodic; the cumulative reaches c_0 there).
  std::vector<double> taus;
  for (int n = 0; n < bins; ++n) taus.push_back(frame.BinTimeOfFlightNs(n));
  const auto series = [&](const std::vector<float>& planes) {
    std::vector<double> values;
    for (int n = 0; n < bins; ++n) values.push_back(frame.at(planes, n, x, y));
    return values;
  };
  std::vector<double> density, lower, upper, cumulative;
  if (has_density) density = series(frame.density);
  if (has_bounds) lower = series(frame.bounds_lower), upper = series(frame.bounds_upper);
  if (has_cumulative) cumulative = series(frame.cumulative);
  std::vector<double> phases, weights;
  double uniform = std::nan("");
  if (has_pisarenko) {
    for (int k = 0; k < frame.order; ++k) {
      const double phase = frame.at(frame.pisarenko_phase, k, x, y);
      const double weight = frame.at(frame.pisarenko_weight, k, x, y);
      if (std::isfinite(phase) && std::isfinite(weight)) {
        phases.push_back(phase);
        weights.push_back(weight);
      }
    }
    uniform = frame.at(frame.pisarenko_uniform, 0, x, y);
  }

  double density_max = 0.0;
  for (const std::vector<double>* values : {&density, &upper}) {
    for (double v : *values) {
      if (std::isfinite(v)) density_max = std::max(density_max, v);
    }
  }
  if (std::isfinite(uniform)) density_max = std::max(density_max, uniform / two_pi);
  double weight_max = 0.0;
  for (double w : weights) weight_max = std::max(weight_max, w);
  double cumulative_max = std::isfinite(c0) ? c0 : 0.0;
  for (double v : cumulative) {
    if (std::isfinite(v)) cumulative_max = std::max(cumulative_max, v);
  }

  const Panel top{.area = cv::Rect(kLeft, kTop, kPlotWidth, kDensityHeight),
                  .max = AxisMax(density_max),
                  .tau_max_ns = period_ns};
  const Panel bottom{
      .area = cv::Rect(kLeft, kTop + kDensityHeight + kPanelGap, kPlotWidth, kCumulativeHeight),
      .max = AxisMax(cumulative_max),
      .tau_max_ns = period_ns};
  const double weight_axis = AxisMax(weight_max);

  // Title and the range scale along the top.
  const std::string range_text =
      frame.range_m.empty() ? "" : absl::StrFormat(", range %.3f m", frame.at(frame.range_m, 0, x, y));
  DrawText(canvas,
           absl::StrCat("pixel (", x, ", ", y, "), frame ", frame.index, ": c0 = ",
                        FormatValue(c0), range_text, ", flags: ",
                        frame.flags.empty() ? "?" : FlagNames(frame.flags[frame.pixel_index(x, y)])),
           cv::Point(kPixelPlotWidth / 2, 20), 0.5, kTitleScale);
  const double range_max_m = RangeOfTimeOfFlightNs(period_ns);
  const std::vector<double> range_ticks = NiceTicks(0.0, range_max_m, 8);
  const double range_step = range_ticks.size() >= 2 ? range_ticks[1] - range_ticks[0] : 1.0;
  for (double tick : range_ticks) {
    const int tx = top.X(tick / range_max_m * period_ns);
    cv::line(canvas, cv::Point(tx, kTop - 5), cv::Point(tx, kTop), kBlack);
    DrawText(canvas, FormatTick(tick, range_step), cv::Point(tx, kTop - 9), 0.5);
  }
  DrawText(canvas, "range c*tau/2 [m]", cv::Point(kLeft + kPlotWidth / 2, kTop - 28), 0.5);

  // Density panel.
  TimeTicks(canvas, top, false);
  VerticalAxis(canvas, top, top.max, -1, absl::StrCat("density [", kDensityUnit, "]"), true);
  if (has_bounds) {
    std::vector<cv::Point> band;
    for (int n = 0; n <= bins; ++n) {
      const int i = n % bins;
      if (std::isfinite(upper[i])) band.push_back({top.X(n < bins ? taus[i] : period_ns), top.Y(upper[i])});
    }
    for (int n = bins; n >= 0; --n) {
      const int i = n % bins;
      if (std::isfinite(lower[i])) band.push_back({top.X(n < bins ? taus[i] : period_ns), top.Y(lower[i])});
    }
    if (band.size() >= 3) {
      cv::fillPoly(canvas, std::vector<std::vector<cv::Point>>{band}, kBandColour, cv::LINE_AA);
    }
  }
  const auto curve = [&](const Panel& panel, const std::vector<double>& values, double last) {
    std::vector<cv::Point> points;
    for (int n = 0; n < bins; ++n) {
      if (std::isfinite(values[n])) points.push_back({panel.X(taus[n]), panel.Y(values[n])});
    }
    if (std::isfinite(last)) points.push_back({panel.X(period_ns), panel.Y(last)});
    return points;
  };
  if (has_bounds) {
    Polyline(canvas, curve(top, upper, upper[0]), kBandEdgeColour);
    Polyline(canvas, curve(top, lower, lower[0]), kBandEdgeColour);
  }
  if (std::isfinite(uniform)) {
    DashedLine(canvas, {top.X(0.0), top.Y(uniform / two_pi)},
               {top.X(period_ns), top.Y(uniform / two_pi)}, kUniformColour);
  }
  if (has_density) Polyline(canvas, curve(top, density, density[0]), kDensityColour, 2);
  if (has_pisarenko) {
    VerticalAxis(canvas, top, weight_axis, +1, absl::StrCat("Pisarenko weight [", kLightUnit, "]"),
                 false);
    for (size_t k = 0; k < phases.size(); ++k) {
      const int sx = top.X(frame.TimeOfFlightNs(phases[k]));
      const int sy = top.Y(weights[k], weight_axis);
      cv::line(canvas, {sx, top.area.y + top.area.height}, {sx, sy}, kPisarenkoColour, 2,
               cv::LINE_AA);
      cv::circle(canvas, {sx, sy}, 4, kPisarenkoColour, cv::FILLED, cv::LINE_AA);
    }
  }
  cv::rectangle(canvas, top.area, kBlack);

  // Cumulative panel.
  TimeTicks(canvas, bottom, true);
  VerticalAxis(canvas, bottom, bottom.max, -1, absl::StrCat("light [", kLightUnit, "]"), true);
  if (std::isfinite(c0)) {
    DashedLine(canvas, {bottom.X(0.0), bottom.Y(c0)}, {bottom.X(period_ns), bottom.Y(c0)}, kBlack);
  }
  if (has_pisarenko && std::isfinite(uniform)) {
    // F_P(tau) = uniform * tau / T + the weights of the returns before tau.
    std::vector<cv::Point> staircase;
    for (int i = 0; i <= kPlotWidth; ++i) {
      const double tau = period_ns * i / kPlotWidth;
      double value = uniform * tau / period_ns;
      for (size_t k = 0; k < phases.size(); ++k) {
        if (frame.TimeOfFlightNs(phases[k]) <= tau) value += weights[k];
      }
      staircase.push_back({bottom.X(tau), bottom.Y(value)});
    }
    Polyline(canvas, staircase, kPisarenkoColour);
  }
  if (has_cumulative) Polyline(canvas, curve(bottom, cumulative, c0), kDensityColour, 2);
  cv::rectangle(canvas, bottom.area, kBlack);
  const int below = bottom.area.y + bottom.area.height;
  DrawText(canvas, "round-trip time of flight tau [ns]", cv::Point(kLeft + kPlotWidth / 2, below + 40),
           0.5);

  // Legend: what is drawn, in two rows.
  struct Entry {
    cv::Scalar colour;
    std::string text;
    bool band;
  };
  std::vector<Entry> entries;
  if (has_density) entries.push_back({kDensityColour, "MESE density (top), cumulative (bottom)", false});
  if (has_bounds) {
    entries.push_back({kBandColour,
                       absl::StrCat("bounds of the Poisson-smoothed density, r = ",
                                    FormatValue(frame.bounds_r.value_or(0.0))),
                       true});
  }
  if (has_pisarenko) {
    entries.push_back({kPisarenkoColour, "Pisarenko returns (weights, right axis), cumulative", false});
    entries.push_back({kUniformColour, "Pisarenko uniform part / 2 pi", false});
  }
  if (std::isfinite(c0)) entries.push_back({kBlack, "c0 (all light)", false});
  int lx = kLeft, ly = below + 62;
  for (const Entry& entry : entries) {
    const int width = 30 + TextWidth(entry.text) + 20;
    if (lx + width > kPixelPlotWidth - 10) lx = kLeft, ly += 20;
    if (entry.band) {
      cv::rectangle(canvas, cv::Rect(lx, ly - 9, 22, 10), entry.colour, cv::FILLED);
    } else {
      cv::line(canvas, {lx, ly - 4}, {lx + 22, ly - 4}, entry.colour, 2, cv::LINE_AA);
    }
    DrawText(canvas, entry.text, cv::Point(lx + 28, ly));
    lx += width;
  }
  return canvas;
}

}  // namespace transient::tools
