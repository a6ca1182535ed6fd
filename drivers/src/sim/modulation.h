// The effective modulation of the simulated sensor (thesis §8.2.1): the periodic
// cross-correlation s of the illumination and the differential sensor modulation, and its
// combination with the sub-exposure split of the schedule (thesis §8.3.1, eq. 8.7).
#pragma once

#include <cmath>
#include <span>
#include <vector>

#include "transient/drivers/simulator.h"
#include "transient/reconstruct/acquisition.h"
#include "transient/reconstruct/moments.h"

namespace transient::sim {

// s(x), 2*pi-periodic, in [-1, 1], with s(x - pi) = -s(x) (only odd harmonics), s = cos for the
// sinusoid. `duty` is the illumination duty cycle of the square waveform.
double EffectiveModulation(Waveform waveform, double duty, double x);

// The split effective modulation t(x) = sum_k w_k s(x - theta_k) of one modulated exposure,
// tabulated once so that a Dirac return costs one interpolated look-up per exposure, and its
// Fourier coefficients T_h = S_h * sum_k w_k exp(-i*h*theta_k) for continuous returns, whose
// moments at h*nu are closed-form.
class SplitModulation {
 public:
  SplitModulation(Waveform waveform, double duty, std::span<const SubExposure> split);

  // t(x) for any real x, by linear interpolation of kTableSize samples per period: the error
  // is below 3e-7 of the amplitude for the sinusoid (the curvature bound h^2/8).
  double operator()(double x) const {
    double u = x * kScale;
    u -= std::floor(u * (1.0 / kTableSize)) * kTableSize;
    int i = static_cast<int>(u);
    if (i >= kTableSize) i = kTableSize - 1;  // u rounded up to the period
    const double frac = u - i;
    return table_[i] + frac * (table_[i + 1] - table_[i]);
  }

  // T_h for h = 0..highest_harmonic() (T_h = 0 for even h); harmonics above were dropped where
  // |S_h| fell below kRelativeCutoff * |S_1|.
  std::span<const Complex> coefficients() const { return coefficients_; }
  int highest_harmonic() const { return static_cast<int>(coefficients_.size()) - 1; }
  // max_{h' >= h} |T_h'|: a bound for truncating a series early.
  double tail_bound(int h) const { return tail_bound_[h]; }

  static constexpr int kTableSize = 4096;
  static constexpr double kRelativeCutoff = 1e-9;
  static constexpr int kMaxHarmonic = 2047;

 private:
  static constexpr double kScale = kTableSize / kTwoPi;
  std::vector<double> table_;  // kTableSize + 1 samples, the last equal to the first
  std::vector<Complex> coefficients_;
  std::vector<double> tail_bound_;
};

}  // namespace transient::sim
