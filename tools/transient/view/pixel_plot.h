// The per-pixel plot of `transient view` (thesis fig. 8.6): the MESE density with the band of
// sharp bounds of the Poisson-smoothed density, the Pisarenko returns as stems with their
// weights and its uniform part, and below it the cumulative light, over one period of round-trip
// time of flight in ns with range c*tau/2 in metres along the top.
#pragma once

#include <opencv2/core.hpp>

#include "transient/formats/transient_frame.h"

namespace transient::tools {

inline constexpr int kPixelPlotWidth = 800;
inline constexpr int kPixelPlotHeight = 680;

// Draws whatever of density, cumulative, bounds and Pisarenko the frame holds for pixel (x, y),
// which must lie in the frame (asserted). 8-bit RGB, kPixelPlotWidth x kPixelPlotHeight.
cv::Mat RenderPixelPlot(const TransientFrame& frame, int x, int y);

}  // namespace transient::tools
