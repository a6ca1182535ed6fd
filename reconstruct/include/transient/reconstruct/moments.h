// Shared vocabulary of the numeric core: trigonometric moment vectors, Toeplitz matrices and
// the conversion between phase and range. Conventions follow DESIGN.md and thesis ch. 2/8.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <complex>
#include <numbers>
#include <span>

#include "transient/reconstruct/physical_constants.h"

namespace transient {

using Complex = std::complex<double>;

// Both parts finite (std::abs would call hypot to say the same).
inline bool IsFinite(Complex z) { return std::isfinite(z.real()) && std::isfinite(z.imag()); }

// The largest number of complex moments c_1..c_m that the core accepts (1 <= m <= kMaxOrder).
inline constexpr int kMaxOrder = 16;
inline constexpr int kMaxMoments = kMaxOrder + 1;

// A Hermitian Toeplitz matrix of at most kMaxMoments rows, kept on the stack.
using ToeplitzMatrix =
    Eigen::Matrix<Complex, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxMoments, kMaxMoments>;
using SmallVector = Eigen::Matrix<Complex, Eigen::Dynamic, 1, 0, kMaxMoments, 1>;

// C(c) = (c_{j-k})_{j,k=0..m} with c_{-j} = conj(c_j) (thesis def. 2.10). Only c_0's real part
// is used: c_0 is real by definition.
ToeplitzMatrix MakeToeplitz(std::span<const Complex> c);

// The eigenvalues of a Hermitian matrix of at most kMaxMoments rows, ascending, and where
// `eigenvectors` is not null its unit eigenvectors, as columns in the same order: Eigen's dense
// SelfAdjointEigenSolver, here for every caller (biasing, Pisarenko) so that the slowest of the
// core's templates to compile is compiled once.
using RealSmallVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxMoments, 1>;
RealSmallVector HermitianEigenvalues(const ToeplitzMatrix& t,
                                     ToeplitzMatrix* eigenvectors = nullptr);

// Trigonometric moments c_j = sum_l w_l exp(i*j*phi_l), j = 0..m, of a sum of Dirac deltas
// (thesis eq. 8.1). `moments` has m+1 entries.
void DiracMoments(std::span<const double> phases, std::span<const double> weights,
                  std::span<Complex> moments);

// Phase phi = 2*pi*f*tau of a round trip; range = c*tau/2 = c*phi/(4*pi*f) (thesis §8.4.3).
inline double PhaseToRange(double phase, double base_frequency_hz) {
  return TimeOfFlightToRange(PhaseToTimeOfFlight(phase, base_frequency_hz));
}
inline double RangeToPhase(double range_m, double base_frequency_hz) {
  return TimeOfFlightToPhase(2.0 * range_m / kSpeedOfLight, base_frequency_hz);
}

// Wraps a phase into [0, 2*pi). Inline, with phases within one turn of [0, 2*pi) handled
// without fmod (range searches wrap ~10^7 phases a second); the results are fmod's:
// x - 2*pi is exact for x in [2*pi, 4*pi) (Sterbenz), fmod(x) = x for x in (-2*pi, 0).
inline double WrapPhase(double phase) {
  if (phase >= 0.0 && phase < kTwoPi) return phase;
  if (phase >= kTwoPi && phase < 2.0 * kTwoPi) return phase - kTwoPi;
  double wrapped = phase > -kTwoPi && phase < 0.0 ? phase : std::fmod(phase, kTwoPi);
  if (wrapped < 0.0) wrapped += kTwoPi;
  if (wrapped >= kTwoPi) wrapped = 0.0;  // fmod of a tiny negative number plus 2*pi
  return wrapped;
}

}  // namespace transient
