// A small SVG plot writer for the benchmark's figures (thesis fig. 8.12 and 8.13): panels with
// axes, ticks, labels with units, lines, steps and points, a legend and a title. No dependency
// beyond the standard library; the output opens in any browser.
#pragma once

#include <string>
#include <vector>

#include "absl/status/status.h"

namespace transient::eval {

enum class SeriesStyle {
  kLine,    // a polyline through the points
  kSteps,   // a step function: constant from x[n] to x[n+1] at y[n]
  kPoints,  // a dot per point
};

struct PlotSeries {
  SeriesStyle style = SeriesStyle::kLine;
  std::vector<double> x, y;  // same length; non-finite points break a line and are skipped
  std::string color = "#000000";
  double width = 1.5;    // stroke width of lines, radius of points, px
  std::string dash;      // SVG stroke-dasharray, e.g. "2,3" for dotted; empty = solid
  double opacity = 1.0;
  std::string label;     // legend entry; empty = not in the legend
};

struct PlotPanel {
  std::string title;
  std::string x_label, y_label;  // with units, e.g. "time of flight τ (ns)"
  // Axis ranges; when low >= high the range is fitted to the data.
  double x_low = 0.0, x_high = 0.0, y_low = 0.0, y_high = 0.0;
  bool equal_scale = false;  // one unit is as long on both axes (a top view)
  std::vector<PlotSeries> series;
};

// Round tick positions (1, 2 or 5 times a power of ten apart) covering [low, high], about
// `target` of them.
std::vector<double> NiceTicks(double low, double high, int target);

// An SVG document with the panels in a grid of `columns` columns under `title`.
std::string RenderSvg(const std::vector<PlotPanel>& panels, int columns, const std::string& title,
                      double panel_width = 380.0, double panel_height = 280.0);

}  // namespace transient::eval
