// Range from a camera's fixed frequencies, the Kinect v2's 16, 80 and 120 MHz (harmonics 2, 10,
// 15 of 8 MHz), on the simulator's corner and mirrors scenes: libfreenect2's unwrapping
// (baselines.h) against transientd's maximum-likelihood unwrapping (phase_unwrapping.h), and a
// two-return fit across the three frequencies that tries to undo multipath. Measurements and
// noise are the benchmark's (experiment.h): m(f) of each pixel's true impulse response, plus
// Gaussian noise of std c_0 / snr on the real and imaginary parts.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "tools/eval/baselines.h"
#include "tools/eval/metrics.h"

namespace transient::eval {

enum class UnwrapMethod { kLibfreenect2, kMaximumLikelihood, kTwoReturn };
// "libfreenect2 unwrapping", "ML unwrapping (transientd)", "two-return fit".
std::string UnwrapMethodName(UnwrapMethod method);

struct MultiFrequencyOptions {
  std::vector<std::string> scenes = {"corner", "mirrors"};
  int width = 163, height = 120;  // the simulator's default camera
  double snr = 70.0;
  uint64_t seed = 1;
  std::vector<bool> noise = {false, true};
  std::vector<UnwrapMethod> methods = {UnwrapMethod::kLibfreenect2,
                                       UnwrapMethod::kMaximumLikelihood, UnwrapMethod::kTwoReturn};
  // Every how many lit pixels one is measured (the two-return fit's grid search costs ~1 ms a
  // pixel); 1 = all.
  int pixel_stride = 4;
};

struct MultiFrequencyRow {
  std::string scene;
  UnwrapMethod method;
  bool noisy = false;
  int pixels = 0;             // lit pixels measured
  double found_share = 0.0;   // pixels with a range
  // Share of the ranges further than 0.5 m from the true first return: a wrong unwrapping
  // candidate, or another return (a mirror path) taken for the first.
  double wrap_errors = 0.0;
  ErrorSummary range_error_mm;  // of the ranges within 0.5 m of the first return
  double median_abs_mm = 0.0;
  double time_per_pixel_us = 0.0;
};

// Every (scene, noise, method). InvalidArgument for a scene the simulator does not know.
absl::StatusOr<std::vector<MultiFrequencyRow>> RunMultiFrequency(
    const MultiFrequencyOptions& options);

// The two-return fit of one pixel: m_j = a_1 exp(i*j*theta_1) + a_2 exp(i*j*theta_2) for the
// harmonics j of `measurements` (of base frequency `base_hz`), a_l >= 0 by least squares,
// (theta_1, theta_2) by a grid search over [0, 2*pi)^2 refined locally; the first return is
// the earlier one unless its weight is below `threshold` times the other's. Radial range in
// metres, NaN for no light.
double TwoReturnRange(const std::vector<Complex>& measurements, const std::vector<int>& harmonics,
                      double base_hz, double threshold = 0.1);

}  // namespace transient::eval
