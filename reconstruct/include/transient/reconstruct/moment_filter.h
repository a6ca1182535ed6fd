// Linear filtering of moment depth maps (moment shadow mapping on camera depth): a separable
// Gaussian of fixed width, and a summed-area table whose box queries choose their own width
// (assignment "Filter the shadow map"; thesis ch. 6, §6.2).
//
// Images are K planar float32 channels (e.g. the power moments b1..b4 and optionally a weight
// plane) of one ImageGeometry: channel k holds its pixels row-major at offset k * pixel_count().
// Filtering is linear, so it commutes with taking moments: a pixel without data should carry
// zero moments and weight 0 in a weight channel, and the caller divides the filtered moments by
// the filtered weight (NaN is not a "no data" marker here: it is rejected, see below).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "transient/reconstruct/image.h"

namespace transient {

// InvalidArgument unless geometry is non-empty, channels >= 1 and `planes` holds exactly
// channels * pixel_count() values; the message names the sizes.
absl::Status ValidatePlanes(ImageGeometry geometry, int channels, std::span<const float> planes);

// A separable Gaussian of standard deviation sigma_px (pixels), truncated at radius
// r = GaussianRadius(sigma_px) = ceil(3 * sigma_px) (smoothing.h) and normalised to sum 1:
//   out(x, y) = sum_{|dx|, |dy| <= r} g(dx) g(dy) in(clamp(x + dx), clamp(y + dy)),
//   g(d) = exp(-d^2 / (2 sigma^2)) / sum_{|e| <= r} exp(-e^2 / (2 sigma^2)).
// Borders clamp to the edge (the edge pixel repeats), so a constant image stays constant up
// to float rounding, and every output is a convex combination of input pixels: the filtered
// moments of valid moment vectors stay valid moment vectors.
//
// Validation, once at Create: sigma_px finite and > 0; the filter 2r + 1 no wider and no
// taller than the image (else InvalidArgument naming sigma, the radius and the image size:
// a wider filter would weigh the repeated edge pixel more than the image itself); channels
// >= 1. Per call: buffer sizes (InvalidArgument), and every input value finite
// (InvalidArgument naming the channel and the pixel; `out` is then left untouched). Finite
// inputs give finite outputs (a convex combination), so the output never holds NaN.
class GaussianMomentFilter {
 public:
  static absl::StatusOr<GaussianMomentFilter> Create(double sigma_px, ImageGeometry geometry,
                                                     int channels);

  // The fast path: float32, a row pass then a column pass over whole rows (both vectorize),
  // fused through a small ring of row-filtered rows; OpenMP threads over bands of rows
  // (GetKernelOptions().threads, kernels.h). `in` and `out` must not overlap. Const: several
  // threads may share one filter.
  absl::Status Apply(std::span<const float> in, std::span<float> out) const;

  // The scalar reference: the direct 2-D convolution above with weights
  // exp(-(dx^2 + dy^2) / (2 sigma^2)) normalised over the (2r + 1)^2 window, in double.
  // Same contract as Apply; slow (O(r^2) per pixel), for tests.
  absl::Status ApplyReference(std::span<const float> in, std::span<float> out) const;

  double sigma_px() const { return sigma_px_; }
  int radius() const { return static_cast<int>(kernel_.size()) - 1; }
  ImageGeometry geometry() const { return geometry_; }
  int channels() const { return channels_; }

 private:
  GaussianMomentFilter(double sigma_px, ImageGeometry geometry, int channels);
  absl::Status CheckInput(std::span<const float> in, std::span<float> out) const;

  double sigma_px_;
  ImageGeometry geometry_;
  int channels_;
  std::vector<float> kernel_;  // normalised half kernel g(0..r)
};

// Per-channel summed-area table (Crow 1984; thesis §6.2) for box filters whose width each query
// chooses, in O(1) per query.
//
// Precision: entries are double. An entry sums up to pixel_count() values, so a float table
// (24-bit mantissa) loses small boxes of large images: at 4096 x 4096 values in [0, 1] (entries
// ~2^23) a one-pixel box at the far corner came out 48% wrong; Kahan compensation of the running
// sum does not help, because each stored entry is itself rounded to float. In double, a float
// value >= 2^-6 has no bits below 2^-29 and an entry <= 2^24 keeps every bit down to 2^-29, so
// such sums are exact and a box mean carries one rounding (measured error 0 at 4096^2); smaller
// values lose bits below ~2^-53 * entry, at worst ~(w + h) * 2^-53 * entry per entry. Unlike the
// thesis's 32-bit modular integers (22.4 bits for a 28 x 28 kernel) this needs no maximal kernel
// size. Memory: 8 bytes per channel and pixel (plus a zero first row and column).
class SummedAreaTable {
 public:
  // Builds the table of `planes` (ValidatePlanes rules; every value finite, else InvalidArgument
  // naming the channel and pixel). Two passes as in thesis §6.2 (row prefix sums, then column
  // prefix sums), OpenMP threads over rows and column blocks.
  static absl::StatusOr<SummedAreaTable> Build(ImageGeometry geometry, int channels,
                                               std::span<const float> planes);

  // Rectangles are inclusive pixel ranges [x0, x1] x [y0, y1], clamped to the image first.
  // A rectangle that is empty (x1 < x0 or y1 < y0) or misses the image has area 0, sum 0 and
  // mean 0: callers that need to tell "no pixels" from "mean 0" check BoxArea.
  int64_t BoxArea(int x0, int y0, int x1, int y1) const;
  double BoxSum(int channel, int x0, int y0, int x1, int y1) const;
  double BoxMean(int channel, int x0, int y0, int x1, int y1) const;
  // All channels' means at once into means[0..channels-1]; returns the area.
  int64_t BoxMeans(int x0, int y0, int x1, int y1, std::span<double> means) const;

  ImageGeometry geometry() const { return geometry_; }
  int channels() const { return channels_; }

 private:
  // The clamped rectangle as half-open table indices; false when it holds no pixels.
  struct Box {
    int64_t top_left, top_right, bottom_left, bottom_right;  // offsets into a table plane
    int64_t area;
  };
  bool Clamp(int x0, int y0, int x1, int y1, Box* box) const;

  ImageGeometry geometry_;
  int channels_ = 0;
  int64_t plane_size_ = 0;  // (width + 1) * (height + 1): a zero first row and column
  // table_[k * plane_size_ + y * (width + 1) + x] = sum of channel k over [0, x) x [0, y).
  std::vector<double> table_;
};

}  // namespace transient
