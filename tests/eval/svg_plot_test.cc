// The SVG writer: round ticks, labelled axes, escaped text, every series drawn.
#include "tools/eval/svg_plot.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace transient::eval {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::Not;

TEST(NiceTicks, AreRoundAndCoverTheRange) {
  EXPECT_THAT(NiceTicks(0.0, 43.48, 6), ElementsAre(0.0, 10.0, 20.0, 30.0, 40.0));
  EXPECT_THAT(NiceTicks(0.0, 1.15, 5), ElementsAre(0.0, 0.5, 1.0));
  const std::vector<double> ticks = NiceTicks(-0.3, 0.3, 6);
  ASSERT_EQ(ticks.size(), 7u);
  for (int i = 0; i < 7; ++i) EXPECT_NEAR(ticks[i], -0.3 + 0.1 * i, 1e-15) << i;
  EXPECT_TRUE(NiceTicks(1.0, 1.0, 5).empty());
}

TEST(RenderSvg, DrawsLabelledAxesSeriesAndLegend) {
  PlotPanel panel;
  panel.title = "MESE <m = 3>";
  panel.x_label = "time of flight τ (ns)";
  panel.y_label = "cumulative light / c₀";
  panel.series.push_back({SeriesStyle::kLine, {0.0, 1.0, 2.0}, {0.0, 0.5, 1.0}, "#d01f1f", 1.5,
                          "", 1.0, "no noise"});
  panel.series.push_back({SeriesStyle::kSteps, {0.0, 1.0}, {0.0, 1.0}, "#1f4fd0", 1.0, "2,3",
                          1.0, "ground truth"});
  panel.series.push_back({SeriesStyle::kPoints, {0.5}, {0.2}, "#888888", 2.0, "", 1.0, ""});
  const std::string svg = RenderSvg({panel}, 1, "A & B");
  EXPECT_THAT(svg, HasSubstr("<svg xmlns=\"http://www.w3.org/2000/svg\""));
  EXPECT_THAT(svg, HasSubstr("A &amp; B"));
  EXPECT_THAT(svg, HasSubstr("MESE &lt;m = 3&gt;"));
  EXPECT_THAT(svg, Not(HasSubstr("<m = 3>")));
  EXPECT_THAT(svg, HasSubstr("time of flight τ (ns)"));
  EXPECT_THAT(svg, HasSubstr("cumulative light / c₀"));
  EXPECT_THAT(svg, HasSubstr("stroke-dasharray=\"2,3\""));
  EXPECT_THAT(svg, HasSubstr(">no noise</text>"));
  EXPECT_THAT(svg, HasSubstr(">ground truth</text>"));
  EXPECT_THAT(svg, HasSubstr("<circle"));
  EXPECT_THAT(svg, HasSubstr("H"));  // the step series moves horizontally first
  EXPECT_THAT(svg, HasSubstr("</svg>"));
}

TEST(RenderSvg, NonFinitePointsBreakTheLine) {
  PlotPanel panel;
  panel.x_label = "x (m)";
  panel.y_label = "y (m)";
  panel.series.push_back({SeriesStyle::kLine, {0.0, 1.0, 2.0, 3.0}, {0.0, 1.0, std::nan(""), 3.0},
                          "#000000", 1.0, "", 1.0, ""});
  const std::string svg = RenderSvg({panel}, 1, "gaps");
  // Two sub-paths: a second moveto after the gap, and nothing drawn at the NaN.
  const size_t begin = svg.find("<path d=\"");
  ASSERT_NE(begin, std::string::npos);
  const size_t end = svg.find('"', begin + 9);
  const std::string d = svg.substr(begin + 9, end - begin - 9);
  EXPECT_EQ(std::count(d.begin(), d.end(), 'M'), 2) << d;
  EXPECT_EQ(std::count(d.begin(), d.end(), 'L'), 1) << d;
  EXPECT_THAT(svg, Not(HasSubstr("nan")));
}

}  // namespace
}  // namespace transient::eval
