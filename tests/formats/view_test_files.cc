// Synthetic reconstruction files with known values, written through ReconstructionFile.
#include "tests/formats/view_test_files.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "transient/reconstruct/reconstructor.h"

namespace transient::tools::testing {

float KnownDensity(int frame, int bin, int64_t pixel) {
  // A wave front: bright where the bin matches the pixel's column (one column later in each
  // frame), plus a small ramp over the pixels.
  const int x = static_cast<int>(pixel % kViewGeometry.width);
  return (bin == x + frame ? 10.0f : 0.0f) + 0.001f * static_cast<float>(pixel);
}

float KnownCumulative(int frame, int bin, int64_t pixel) {
  return static_cast<float>(bin + 1) / kViewBins * KnownC0(frame, pixel);
}

float KnownRange(int frame, int64_t pixel) {
  if (pixel == 2 * kViewGeometry.width + 3) return std::numeric_limits<float>::quiet_NaN();
  return 1.0f + 0.01f * static_cast<float>(pixel) + 0.5f * static_cast<float>(frame);
}

float KnownC0(int frame, int64_t pixel) { return 100.0f + static_cast<float>(pixel + frame); }

void WriteViewReconstruction(const std::string& path) {
  const ReconstructionHeader header{.frames = kViewFrames,
                                    .order = kViewOrder,
                                    .geometry = kViewGeometry,
                                    .phases = UniformPhases(kViewBins),
                                    .bounds_r = 0.5,
                                    .base_frequency_hz = kViewFrequencyHz,
                                    .method = "both",
                                    .bias_epsilon = 4e-3,
                                    .bias_mode = "raise",
                                    .zeroth = "measured",
                                    .threshold = 0.1,
                                    .source = "synthetic"};
  absl::StatusOr<ReconstructionFile> file = ReconstructionFile::Create(path, header);
  ASSERT_TRUE(file.ok()) << file.status();
  const int64_t pixels = kViewGeometry.pixel_count();
  const auto write = [&](Product product, int frame, const std::vector<float>& values) {
    const absl::Status status = file->Write(product, frame, 0, values);
    ASSERT_TRUE(status.ok()) << status;
  };
  for (int f = 0; f < kViewFrames; ++f) {
    std::vector<float> bins(kViewBins * pixels), lower(kViewBins * pixels),
        upper(kViewBins * pixels), cumulative(kViewBins * pixels);
    for (int n = 0; n < kViewBins; ++n) {
      for (int64_t p = 0; p < pixels; ++p) {
        bins[n * pixels + p] = KnownDensity(f, n, p);
        lower[n * pixels + p] = 0.5f * KnownDensity(f, n, p);
        upper[n * pixels + p] = 1.5f * KnownDensity(f, n, p) + 0.1f;
        cumulative[n * pixels + p] = KnownCumulative(f, n, p);
      }
    }
    write(Product::kDensity, f, bins);
    write(Product::kCumulative, f, cumulative);
    write(Product::kBoundsLower, f, lower);
    write(Product::kBoundsUpper, f, upper);
    std::vector<float> range(pixels), c0(pixels), direct(pixels), indirect(pixels),
        uniform(pixels), phase(kViewOrder * pixels), weight(kViewOrder * pixels);
    std::vector<uint8_t> flags(pixels, 0);
    for (int64_t p = 0; p < pixels; ++p) {
      range[p] = KnownRange(f, p);
      c0[p] = KnownC0(f, p);
      direct[p] = 0.6f * c0[p];
      indirect[p] = 0.3f * c0[p];
      uniform[p] = 0.1f * c0[p];
      for (int k = 0; k < kViewOrder; ++k) {
        phase[k * pixels + p] = static_cast<float>(0.5 + 1.5 * k);
        weight[k * pixels + p] = k == 0 ? direct[p] : 0.15f * c0[p];
      }
      if (std::isnan(range[p])) flags[p] = kFlagNoReturn;
      if (p % 5 == 0) flags[p] |= kFlagBiased;
    }
    write(Product::kRange, f, range);
    write(Product::kZerothMoment, f, c0);
    write(Product::kPisarenkoPhase, f, phase);
    write(Product::kPisarenkoWeight, f, weight);
    write(Product::kPisarenkoUniform, f, uniform);
    write(Product::kPisarenkoRange, f, range);
    write(Product::kPisarenkoDirect, f, direct);
    write(Product::kPisarenkoIndirect, f, indirect);
    const absl::Status status = file->WriteFlags(f, flags);
    ASSERT_TRUE(status.ok()) << status;
  }
  const absl::Status closed = file->Close();
  ASSERT_TRUE(closed.ok()) << closed;
}

}  // namespace transient::tools::testing
