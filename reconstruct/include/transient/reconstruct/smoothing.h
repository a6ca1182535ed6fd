// Spatial smoothing of moment images (thesis §8.5): a Gaussian filter on every moment plane to
// reduce noise before reconstruction.
#pragma once

#include <span>
#include <vector>

#include "absl/status/status.h"
#include "transient/reconstruct/image.h"

namespace transient {

// The thesis smooths moment images with a standard deviation of 0.6 pixels (§8.5).
inline constexpr double kDefaultSmoothingSigmaPx = 0.6;
// A wider filter would blur away the scene rather than the noise; also bounds the radius.
inline constexpr double kMaxSmoothingSigmaPx = 10.0;

// The Gaussian filters of this library (here and moment_filter.h) are truncated at radius
// ceil(3 * sigma_px): the tails dropped weigh 0.27% of a 1-D kernel. Requires sigma_px > 0.
int GaussianRadius(double sigma_px);
// The unnormalised half kernel g[d] = exp(-d^2 / (2 sigma_px^2)), d = 0..GaussianRadius(sigma_px).
// Requires sigma_px > 0 and finite.
std::vector<double> GaussianHalfKernel(double sigma_px);

// InvalidArgument unless 0 <= sigma_px <= kMaxSmoothingSigmaPx and finite.
absl::Status ValidateSmoothingSigma(double sigma_px);

// Smooths every plane (real and imaginary, j = 0..m) with a separable Gaussian of standard
// deviation sigma_px, truncated at radius ceil(3 * sigma_px):
//   out(p) = sum_q G(p - q) w(q) in(q) / sum_q G(p - q) w(q),
// where w(q) = 1 for valid pixels whose moments are all finite and 0 otherwise, and q runs over
// the image (no padding: borders are renormalised like invalid pixels). Pixels with w = 0 keep
// their values and contribute nothing; valid pixels always have a non-zero denominator (their
// own weight). sigma_px = 0 changes nothing. Linear in the moments, so it commutes with
// calibration (a per-pixel factor does not commute; calibrate first).
// `planes`: the planes j to smooth (the others are left as they are; each in 0..m); empty: all.
// A schedule with a harmonic set (the Kinect v2's 2, 10, 15 of m = 15) has only those and c_0
// to smooth, the other planes being zeros.
// InvalidArgument for a bad sigma or an image failing MomentImage::Validate().
absl::Status GaussianSmooth(double sigma_px, MomentImage* moments,
                            std::span<const int> planes = {});

}  // namespace transient
