// Range from a few modulation frequencies that are not all the harmonics 1..m (the Kinect v2:
// 16, 80 and 120 MHz = harmonics 2, 10, 15 of 8 MHz): the products a camera without the moment
// reconstruction's harmonics still has — range, depth, amplitude, flags — by phase unwrapping.
//
// Method (single-return maximum likelihood). After calibration (calibration.h), a single return
// at round-trip phase theta of the base frequency f (distance theta / (2*pi) * c / (2f)) has
// c_j = A * exp(i*j*theta) for every measured j. With white noise of equal variance on every
// c_j, the likelihood of theta is maximal where the matched filter
//     S(theta) = sum_j Re(c_j * exp(-i*j*theta)) = sum_j |c_j| cos(arg c_j - j*theta)
// is. S peaks near one of the J candidates theta_n = (arg c_J + 2*pi*n) / J of the highest
// harmonic J (n = 0..J-1); each is scored, the best refined by Newton steps on S, and
// - confidence = S(theta*) / sum_j |c_j| in [-1, 1]: 1 when the phases agree exactly (the
//   coherence of the frequencies; multipath and noise lower it);
// - kFlagAmbiguous (image.h) when another candidate's normalised score comes within
//   `ambiguity_margin` of the best: the frequencies cannot tell the two distances apart (noise, or mixed
//   returns), so the pixel gets no range rather than a wrong one;
// - kFlagLowAmplitude when the mean |c_j| is below `min_amplitude` (sensor units).
// Such pixels and invalid ones hold NaN. Unlike an integer-lattice (Chinese remainder) unwrap
// it weighs each frequency by its amplitude and never rounds a noisy phase in isolation.
#pragma once

#include <complex>
#include <cstdint>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "transient/reconstruct/image.h"

namespace transient {

struct UnwrapOptions {
  double base_frequency_hz = 8e6;  // f: the range is unambiguous within c / (2f)
  std::vector<int> harmonics;      // the measured j (ScheduleOptions::MeasuredHarmonics()),
                                   // without a common factor
  double min_amplitude = 0.0;      // mean |c_j| below it: kFlagLowAmplitude; >= 0
  double ambiguity_margin = 0.05;  // in units of sum_j |c_j|; [0, 2]
  int newton_steps = 3;            // refinement of the best candidate; 0..16

  // Names the violated constraint: at least one harmonic, each 1..kMaxOrder, ...
  absl::Status Validate() const;
};

// One pixel's result.
struct UnwrappedPixel {
  double range_m = 0.0;     // NaN when flagged
  double amplitude = 0.0;   // mean |c_j| over the measured harmonics, sensor units
  double confidence = 0.0;  // S(theta*) / sum |c_j|; NaN with kFlagLowAmplitude
  uint8_t flags = 0;        // kFlagAmbiguous, kFlagLowAmplitude
};

// One pixel from its measured moments c_j (moments[i] for options.harmonics[i]).
// `options` must pass Validate() (asserted in debug builds).
UnwrappedPixel UnwrapPixel(std::span<const std::complex<float>> moments,
                           const UnwrapOptions& options);

// Every pixel of `moments` (planes j of options.harmonics; the others are ignored). Outputs are
// resized to pixel_count(): range_m and amplitude and confidence (NaN where invalid or
// flagged), flags (the moment image's kMomentImageFlags bits, kFlagInvalidInput for invalid
// pixels, and this method's bits). InvalidArgument for bad options or a moment image of lower
// order than the highest harmonic. With the optimized kernels (kernels.h, the default) eight
// pixels at a time on the kernel threads, bit for bit UnwrapPixel's results; with the
// reference kind UnwrapPixel pixel by pixel on one thread.
absl::Status UnwrapImage(const MomentImage& moments, const UnwrapOptions& options,
                         std::vector<float>* range_m, std::vector<float>* amplitude,
                         std::vector<float>* confidence, std::vector<uint8_t>* flags);

}  // namespace transient
