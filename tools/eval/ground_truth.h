// Ground-truth impulse responses of the quality benchmark (thesis §8.5, fig. 8.12 and 8.13):
// sums of Dirac and exponentially modified Gaussian (EMG) returns, their measurements at any
// modulation frequency and their true cumulative distribution on the circle of one period, all
// in closed form. Times of flight are round trips in seconds; weights are amounts of light.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <span>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "drivers/src/sim/random.h"  // the simulator's generator (header-only, private)
#include "transient/drivers/scene_returns.h"
#include "transient/reconstruct/moments.h"

namespace transient::eval {

// The base frequency of the thesis's measurements and the period of the circle on which the
// benchmark compares distributions: T = 1/23 MHz = 43.48 ns.
inline constexpr double kBaseFrequencyHz = 23e6;
inline constexpr double kPeriodS = 1.0 / kBaseFrequencyHz;

// A return: a Dirac (sigma_s = decay_rate = 0) or an EMG, tau_s + N(0, sigma^2) + Exp(rate).
using Return = SceneReturn;

// P(t' <= t) of one return (times 1, not its amplitude). The EMG CDF is
//   Phi(z) - exp(-rate*(t - tau) + rate^2 sigma^2 / 2) Phi(z - rate*sigma), z = (t - tau)/sigma,
// with Phi written by erfc and the second term rearranged where it would overflow.
double ReturnCdf(const Return& r, double t);
// Density of a continuous return per second (0 for a Dirac, which has none).
double ReturnDensity(const Return& r, double t);
// Mode of a continuous return (tau_s for a Dirac), by golden-section search on the density,
// accurate to ~1e-6 of its spread.
double ReturnMode(const Return& r);

// An impulse response: returns sorted by tau_s.
struct ImpulseResponse {
  std::vector<Return> returns;

  // Total light: the zeroth moment c_0.
  double TotalLight() const;
  // m(f) = sum_l a_l E exp(i*2*pi*f*t_l), the noise-free measurement at frequency f (thesis
  // eq. 8.1 with phi = 2*pi*f*tau); TotalLight() at f = 0.
  Complex Measure(double frequency_hz) const;
  // The response wrapped onto the circle of period `period_s`: the light whose time of flight
  // modulo the period lies in [0, tau), for tau in [0, period]. This is the distribution whose
  // trigonometric moments are the measurements at multiples of 1/period.
  double CumulativeOnCircle(double tau_s, double period_s) const;
  // Light with time of flight outside [0, period_s): what wrapping moves.
  double LightOutside(double period_s) const;
  // Times of flight of the Dirac returns modulo `period_s`: where the cumulative jumps.
  std::vector<double> JumpsOnCircle(double period_s) const;
  // The first return as the product's range estimate defines it (thesis §8.4.3): the earliest
  // return whose amplitude is at least `threshold` times the largest; its time of flight is
  // the Dirac's delay or the EMG's mode. NaN without returns.
  double FirstReturnTau(double threshold) const;
};

// The simulator's deterministic random stream (xoshiro256+ seeded by SplitMix64 from a tuple of
// keys): the same keys give the same numbers on every platform and standard library.
using RandomStream = sim::Random;

// Parameters of the synthetic ground truths (documented in the report).
struct SyntheticTruthOptions {
  double first_delay_s = 2e-9, last_delay_s = 38e-9;  // sparse returns' delays
  double min_separation_s = 3e-9;                     // between two returns of one response
  double min_weight = 0.3, max_weight = 1.0;          // amplitudes, uniform
  // Continuous returns (thesis fig. 8.12b): onsets in [first_onset_s, last_onset_s], Gaussian
  // sigma and exponential mean 1/rate uniform in the given ranges; the onsets keep 5 sigma
  // above 0 and the tails decay by e^-9 before T, so wrapping moves a negligible amount of
  // light (measured and reported as LightOutside).
  double first_onset_s = 4e-9, last_onset_s = 20e-9;
  double min_sigma_s = 0.2e-9, max_sigma_s = 0.8e-9;
  double min_tail_s = 0.5e-9, max_tail_s = 2.5e-9;
  // K-sparse responses: K Dirac delays anywhere in [ksparse_margin_s, T - ksparse_margin_s],
  // separated by ksparse_min_separation_s.
  double ksparse_margin_s = 1e-9, ksparse_min_separation_s = 2e-9;
};

// `count` delays uniform in [low, high], pairwise at least `separation` apart (rejection
// sampling), sorted. Asserts that such delays exist.
std::vector<double> SeparatedDelays(int count, double low, double high, double separation,
                                    RandomStream& random);

// Three Dirac returns (thesis fig. 8.12a).
ImpulseResponse RandomSparse(int count, const SyntheticTruthOptions& options,
                             RandomStream& random);
// Three EMG returns (thesis fig. 8.12b, Heide et al. 2014).
ImpulseResponse RandomContinuous(int count, const SyntheticTruthOptions& options,
                                 RandomStream& random);
// K Dirac returns anywhere in the period: Pisarenko's exact case for K = m (thesis §8.4.1).
ImpulseResponse RandomKSparse(int k, const SyntheticTruthOptions& options, RandomStream& random);

// The simulator's `corner` scene (thesis fig. 8.13): per pixel a Dirac (direct path) and an
// EMG (one diffuse bounce).
struct CornerTruth {
  CameraInfo camera;
  std::vector<ImpulseResponse> pixels;  // row-major, empty response where nothing returns
  std::vector<int64_t> lit_pixels;      // indices of pixels with a return
  int scanline_row = 0;                 // the row shown in the top view (middle of the image)
};
absl::StatusOr<CornerTruth> MakeCornerTruth(int width, int height);
// The same for any scene of the simulator ("mirrors": three Dirac returns per pixel).
absl::StatusOr<CornerTruth> MakeSceneTruth(absl::string_view scene, int width, int height);

}  // namespace transient::eval
