// SVG plot writer (svg_plot.h).
#include "tools/eval/svg_plot.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace transient::eval {
namespace {

// Margins of a panel inside its cell, px: room for tick labels and axis labels.
constexpr double kLeft = 62.0, kRight = 14.0, kTop = 30.0, kBottom = 46.0;
constexpr double kTitleHeight = 34.0;

std::string Escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string FormatTick(double value, double step) {
  if (std::abs(value) < 1e-9 * step) value = 0.0;
  return absl::StrFormat("%.*f", std::max(0, -static_cast<int>(std::floor(std::log10(step)))),
                         value);
}

struct Range {
  double low, high;
};

Range DataRange(const PlotPanel& panel, bool x_axis) {
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (const PlotSeries& s : panel.series) {
    for (double v : x_axis ? s.x : s.y) {
      if (std::isfinite(v)) low = std::min(low, v), high = std::max(high, v);
    }
  }
  if (!(low <= high)) return {0.0, 1.0};
  if (low == high) return {low - 0.5, high + 0.5};
  const double pad = 0.04 * (high - low);
  return {low - pad, high + pad};
}

void RenderPanel(const PlotPanel& panel, double x0, double y0, double width, double height,
                 int index, std::string* svg) {
  Range xr = panel.x_low < panel.x_high ? Range{panel.x_low, panel.x_high} : DataRange(panel, true);
  Range yr = panel.y_low < panel.y_high ? Range{panel.y_low, panel.y_high} : DataRange(panel, false);
  const double plot_w = width - kLeft - kRight, plot_h = height - kTop - kBottom;
  if (panel.equal_scale) {  // widen the range of the axis that has room to spare
    const double scale = std::min(plot_w / (xr.high - xr.low), plot_h / (yr.high - yr.low));
    const double xc = 0.5 * (xr.low + xr.high), yc = 0.5 * (yr.low + yr.high);
    xr = {xc - 0.5 * plot_w / scale, xc + 0.5 * plot_w / scale};
    yr = {yc - 0.5 * plot_h / scale, yc + 0.5 * plot_h / scale};
  }
  const double left = x0 + kLeft, top = y0 + kTop;
  auto px = [&](double x) { return left + (x - xr.low) / (xr.high - xr.low) * plot_w; };
  auto py = [&](double y) { return top + plot_h - (y - yr.low) / (yr.high - yr.low) * plot_h; };

  absl::StrAppendFormat(svg, "<g>\n<clipPath id=\"clip%d\"><rect x=\"%.1f\" y=\"%.1f\" "
                        "width=\"%.1f\" height=\"%.1f\"/></clipPath>\n",
                        index, left, top, plot_w, plot_h);
  absl::StrAppendFormat(svg,
                        "<rect x=\"%.1f\" y=\"%.1f\" width=\"%.1f\" height=\"%.1f\" fill=\"white\" "
                        "stroke=\"#444\" stroke-width=\"1\"/>\n",
                        left, top, plot_w, plot_h);
  // Ticks, grid and tick labels.
  const std::vector<double> x_ticks = NiceTicks(xr.low, xr.high, 6);
  const double x_step = x_ticks.size() > 1 ? x_ticks[1] - x_ticks[0] : 1.0;
  for (double t : x_ticks) {
    const double x = px(t);
    absl::StrAppendFormat(svg,
                          "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#ddd\"/>"
                          "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#444\"/>"
                          "<text x=\"%.1f\" y=\"%.1f\" font-size=\"11\" text-anchor=\"middle\">%s"
                          "</text>\n",
                          x, top, x, top + plot_h, x, top + plot_h, x, top + plot_h + 5, x,
                          top + plot_h + 17, FormatTick(t, x_step));
  }
  const std::vector<double> y_ticks = NiceTicks(yr.low, yr.high, 5);
  const double y_step = y_ticks.size() > 1 ? y_ticks[1] - y_ticks[0] : 1.0;
  for (double t : y_ticks) {
    const double y = py(t);
    absl::StrAppendFormat(svg,
                          "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#ddd\"/>"
                          "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#444\"/>"
                          "<text x=\"%.1f\" y=\"%.1f\" font-size=\"11\" text-anchor=\"end\">%s"
                          "</text>\n",
                          left, y, left + plot_w, y, left - 5, y, left, y, left - 7, y + 4,
                          FormatTick(t, y_step));
  }
  // Axis labels and the panel title.
  absl::StrAppendFormat(svg,
                        "<text x=\"%.1f\" y=\"%.1f\" font-size=\"12\" text-anchor=\"middle\">%s"
                        "</text>\n",
                        left + 0.5 * plot_w, y0 + height - 8, Escape(panel.x_label));
  absl::StrAppendFormat(svg,
                        "<text x=\"%.1f\" y=\"%.1f\" font-size=\"12\" text-anchor=\"middle\" "
                        "transform=\"rotate(-90 %.1f %.1f)\">%s</text>\n",
                        x0 + 14, top + 0.5 * plot_h, x0 + 14, top + 0.5 * plot_h,
                        Escape(panel.y_label));
  absl::StrAppendFormat(svg,
                        "<text x=\"%.1f\" y=\"%.1f\" font-size=\"13\" font-weight=\"bold\" "
                        "text-anchor=\"middle\">%s</text>\n",
                        left + 0.5 * plot_w, y0 + 20, Escape(panel.title));
  // Data.
  absl::StrAppendFormat(svg, "<g clip-path=\"url(#clip%d)\">\n", index);
  for (const PlotSeries& s : panel.series) {
    const std::string stroke = absl::StrFormat(
        "stroke=\"%s\" stroke-width=\"%.2f\" stroke-opacity=\"%.2f\"%s", s.color, s.width,
        s.opacity, s.dash.empty() ? "" : absl::StrCat(" stroke-dasharray=\"", s.dash, "\""));
    if (s.style == SeriesStyle::kPoints) {
      for (size_t n = 0; n < s.x.size() && n < s.y.size(); ++n) {
        if (!std::isfinite(s.x[n]) || !std::isfinite(s.y[n])) continue;
        absl::StrAppendFormat(svg,
                              "<circle cx=\"%.2f\" cy=\"%.2f\" r=\"%.2f\" fill=\"%s\" "
                              "fill-opacity=\"%.2f\"/>\n",
                              px(s.x[n]), py(s.y[n]), s.width, s.color, s.opacity);
      }
      continue;
    }
    std::string path;
    bool pen_down = false;
    for (size_t n = 0; n < s.x.size() && n < s.y.size(); ++n) {
      if (!std::isfinite(s.x[n]) || !std::isfinite(s.y[n])) {
        pen_down = false;
        continue;
      }
      if (s.style == SeriesStyle::kSteps && pen_down) {
        absl::StrAppendFormat(&path, "H%.2f", px(s.x[n]));
      }
      absl::StrAppendFormat(&path, "%s%.2f,%.2f", pen_down ? "L" : "M", px(s.x[n]), py(s.y[n]));
      pen_down = true;
    }
    if (!path.empty()) {
      absl::StrAppendFormat(svg, "<path d=\"%s\" fill=\"none\" %s/>\n", path, stroke);
    }
  }
  absl::StrAppend(svg, "</g>\n");
  // Legend, top left inside the plot.
  double ly = top + 14;
  for (const PlotSeries& s : panel.series) {
    if (s.label.empty()) continue;
    const double lx = left + 8;
    if (s.style == SeriesStyle::kPoints) {
      absl::StrAppendFormat(svg, "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"3\" fill=\"%s\"/>", lx + 9,
                            ly - 4, s.color);
    } else {
      absl::StrAppendFormat(svg,
                            "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"%s\" "
                            "stroke-width=\"%.2f\"%s/>",
                            lx, ly - 4, lx + 18, ly - 4, s.color, std::max(s.width, 1.5),
                            s.dash.empty() ? "" : absl::StrCat(" stroke-dasharray=\"", s.dash, "\""));
    }
    absl::StrAppendFormat(svg, "<text x=\"%.1f\" y=\"%.1f\" font-size=\"11\">%s</text>\n", lx + 24,
                          ly, Escape(s.label));
    ly += 15;
  }
  absl::StrAppend(svg, "</g>\n");
}

}  // namespace

std::vector<double> NiceTicks(double low, double high, int target) {
  std::vector<double> ticks;
  if (!(high > low) || !std::isfinite(low) || !std::isfinite(high) || target < 1) return ticks;
  const double rough = (high - low) / target;
  const double power = std::pow(10.0, std::floor(std::log10(rough)));
  double step = power;
  for (double factor : {1.0, 2.0, 5.0, 10.0}) {
    step = factor * power;
    if (step >= rough) break;
  }
  // Multiples of the step computed one by one: no rounding accumulates along the axis.
  const int64_t first = static_cast<int64_t>(std::ceil(low / step - 1e-9));
  const int64_t last = static_cast<int64_t>(std::floor(high / step + 1e-9));
  for (int64_t k = first; k <= last; ++k) ticks.push_back(k == 0 ? 0.0 : k * step);
  return ticks;
}

std::string RenderSvg(const std::vector<PlotPanel>& panels, int columns, const std::string& title,
                      double panel_width, double panel_height) {
  columns = std::max(1, std::min<int>(columns, std::max<size_t>(panels.size(), 1)));
  const int rows = static_cast<int>((panels.size() + columns - 1) / columns);
  const double width = columns * panel_width, height = kTitleHeight + rows * panel_height;
  std::string svg = absl::StrFormat(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" "
      "viewBox=\"0 0 %.0f %.0f\" font-family=\"sans-serif\">\n"
      "<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n"
      "<text x=\"%.1f\" y=\"22\" font-size=\"15\" font-weight=\"bold\" text-anchor=\"middle\">%s"
      "</text>\n",
      width, height, width, height, 0.5 * width, Escape(title));
  for (size_t i = 0; i < panels.size(); ++i) {
    const int row = static_cast<int>(i) / columns, column = static_cast<int>(i) % columns;
    RenderPanel(panels[i], column * panel_width, kTitleHeight + row * panel_height, panel_width,
                panel_height, static_cast<int>(i), &svg);
  }
  absl::StrAppend(&svg, "</svg>\n");
  return svg;
}

}  // namespace transient::eval
