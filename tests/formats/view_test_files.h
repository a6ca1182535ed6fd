// Small synthetic reconstruction files for the tests of `transient view` and its reader,
// written with ReconstructionFile and known values in every product.
#pragma once

#include <cstdint>
#include <string>

#include "transient/formats/reconstruction_file.h"

namespace transient::tools::testing {

inline constexpr ImageGeometry kViewGeometry = {.width = 12, .height = 8};
inline constexpr int kViewFrames = 2;
inline constexpr int kViewBins = 16;
inline constexpr int kViewOrder = 3;
inline constexpr double kViewFrequencyHz = 20e6;  // one period: 50 ns, 3.125 ns per bin

// The known values (frame f, bin or return n, pixel p = y * width + x) the file holds.
float KnownDensity(int frame, int bin, int64_t pixel);
float KnownCumulative(int frame, int bin, int64_t pixel);
// NaN at pixel (3, 2) in every frame, else 1 + 0.01 * pixel + 0.5 * frame.
float KnownRange(int frame, int64_t pixel);
float KnownC0(int frame, int64_t pixel);

// Writes a file of kViewFrames frames of kViewGeometry, method `both`, with /bounds (r = 0.5).
void WriteViewReconstruction(const std::string& path);

}  // namespace transient::tools::testing
