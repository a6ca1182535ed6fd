// Related methods that the quality benchmark (`transient eval`) compares with the thesis's
// MESE and Pisarenko estimates (thesis §8.5, fig. 8.12 and 8.13). Each is implemented from its
// paper's description for the synthetic, purely sinusoidal setting of the benchmark; none is
// in the product's hot path.
//
// Conventions shared by all of them: a measurement at modulation frequency f of an impulse
// response with returns of weight a_l at time of flight tau_l is the complex value
//   m(f) = sum_l a_l exp(i * 2*pi * f * tau_l),
// the sign convention of the project's trigonometric moments (DiracMoments, thesis eq. 8.1)
// with phase phi = 2*pi*f*tau. Times of flight are round trips, in seconds.
//
// What every method guarantees for any finite input: returns sorted by time of flight, each
// time in [0, 1/f) for the method's lowest frequency f, every weight finite and > 0, never NaN.
// A method may return fewer returns than it models (none for an all-zero input).
#pragma once

#include <complex>
#include <span>
#include <vector>

#include "absl/status/statusor.h"

namespace transient::eval {

using Complex = std::complex<double>;

// Returns of a sparse reconstruction, sorted by time of flight, each in [0, period) of the
// method's lowest frequency. Weights are the reconstructed amounts of light (> 0).
struct SparseReturns {
  std::vector<double> time_of_flight_s;
  std::vector<double> weight;
};

// Naive range (single-frequency phase): one return at the phase of m(f), wrapped into
// [0, 1/f), with weight |m(f)|. No return for m(f) == 0, and none (rather than an error, since
// the signature has no status) for a non-finite measurement or a frequency that is not finite
// and > 0.
SparseReturns SingleFrequencyPhase(Complex measurement, double frequency_hz);

// The two-return Dirac model of Godbaz, Cree & Dorrington (2012): measurements at
// k * base_frequency_hz, k = 1..4 (11, 22, 33, 44 MHz in the thesis), explained exactly by two
// Dirac returns in closed form. `measurements` holds m(k f) for k = 1..4 (4 values).
//
// Formulation (a Prony-type closed form of the paper's model): m_k = a1 z1^k + a2 z2^k
// obeys m_{k+2} = s m_{k+1} - p m_k with s = z1 + z2, p = z1 z2; Cramer's rule on k = 1, 2
// gives s and p, the quadratic z^2 - s z + p gives z1, z2, and tau_l = arg(z_l) / (2 pi f)
// wrapped into [0, 1/f). Weights are the real least-squares fit of unit returns at tau_l to all
// four measurements (see baselines.cc for why real, not |complex|). Degenerate cases: a
// singular 2x2 system (one return, or two at the same time) gives one return from a one-pole
// fit; weights that come out <= 0 (noise) drop their return and the rest are refit; an
// all-zero input gives no return.
// InvalidArgument for a wrong count, non-finite input, or a frequency that is not finite and
// > 0.
absl::StatusOr<SparseReturns> GodbazTwoDirac(std::span<const Complex> measurements,
                                             double base_frequency_hz);

// Largest `returns` that Spumic accepts (the root finder's degree limit is larger).
inline constexpr int kMaxSpumicReturns = 16;

// SPUMIC (Kirmani, Benedetti & Chou 2013): simultaneous phase unwrapping and multipath
// cancellation by spectral estimation of `returns` sparse returns from measurements at
// k * base_frequency_hz, k = 1..K (11..66 MHz, K = 6, two returns in the thesis).
// `measurements` holds m(k f) for k = 1..K; requires K >= 2 * returns.
//
// Formulation: total-least-squares annihilating filter (Prony): the null vector h of the
// (K - returns) x (returns + 1) Hankel matrix (m_{i+j}) (smallest right singular vector) has
// the z_l = exp(i 2 pi f tau_l) as roots of sum_j h_j z^j. Before that, `cadzow_iterations`
// rounds of Cadzow denoising (rank-`returns` truncation of the most square Hankel matrix of
// the data, then anti-diagonal averaging) may be applied; 0, the default, is the plain
// estimator. Weights as for GodbazTwoDirac (real least squares on all K measurements, returns
// with weight <= 0 dropped and the rest refit).
// InvalidArgument for K < 2 * returns, returns outside [1, kMaxSpumicReturns], negative
// cadzow_iterations, non-finite input, or a frequency that is not finite and > 0.
absl::StatusOr<SparseReturns> Spumic(std::span<const Complex> measurements,
                                     double base_frequency_hz, int returns = 2,
                                     int cadzow_iterations = 0);

// Limits on Sra's grid_bins.
inline constexpr int kMinSraGridBins = 8;
inline constexpr int kMaxSraGridBins = 1 << 14;

// SRA (Freedman, Krupka, Smolin, Leichter & Schmidt 2014): a sparse non-negative combination
// of single returns on a grid of `grid_bins` times of flight over one period of the lowest
// frequency, fitted by linear programming (GLPK) with tolerance `epsilon` (0.05 in the thesis,
// measurements at 23, 46, 69 MHz). `frequencies_hz` and `measurements` have the same length.
//
// Formulation (an LP): with v the 2K real and imaginary parts of the measurements, Phi the
// 2K x grid_bins dictionary of unit returns at tau_n = n / (grid_bins * f_min),
//   minimize sum_n x_n  subject to  ||Phi x - v||_1 <= epsilon * ||v||_1,  x >= 0.
// Minimizing total brightness is what biases SRA towards sparsity and less brightness
// (thesis §8.5.1). For one return of weight a on a grid point the optimum total weight lies in
// [a (1 - 1.21 epsilon), a (1 - epsilon)] (derivation in baselines.cc). The LP also spends the
// budget on moving returns: by up to ~epsilon ||v||_1 / (a sum_k f_k / f_min) radians at f_min
// (measured for one return at 23/46/69 MHz, epsilon = 0.05: up to 1.4 bins of 512, 0.3% of the
// period, whatever the grid), so a finer grid does not make SRA more precise. Bins with
// x_n > 1e-6 * sum x are kept; runs of adjacent kept bins (cyclically) merge into one return at
// their weighted mean time with their summed weight.
// InvalidArgument for mismatched or empty spans, a frequency that is not finite and > 0,
// non-finite measurements, epsilon outside (0, 1), grid_bins outside
// [kMinSraGridBins, kMaxSraGridBins]. FailedPrecondition when no non-negative combination of
// the grid returns fits within epsilon (cannot happen when the frequencies are distinct
// integer multiples h * f_min with h < grid_bins / 2: then the grid returns sum to zero and span
// the measurement space, so their cone is all of it). Internal, with GLPK's code,
// when GLPK fails. Safe to call from several threads (Debian's libglpk keeps its environment
// in thread-local storage; Sra frees it when each calling thread exits). Cost (Release, 3
// frequencies, on this project's shared 2-core machine): ~0.1 ms at 128 bins, 0.6-1.5 ms at
// 512, 2.5-4.8 ms at 1024, growing about quadratically (dual simplex iterations scale with the
// grid).
absl::StatusOr<SparseReturns> Sra(std::span<const double> frequencies_hz,
                                  std::span<const Complex> measurements, double epsilon = 0.05,
                                  int grid_bins = 512);

// libfreenect2's per-pixel phase unwrapping of the Kinect v2 (its CPU depth processor,
// src/cpu_depth_packet_processor.cpp at fd64c5d, stage 2, rules written from its description):
// the phases theta_80, theta_16, theta_120 in [0, 2*pi) scaled to t0 = 3*theta_80/(2*pi),
// t1 = 15*theta_16/(2*pi), t2 = 2*theta_120/(2*pi); the unwrapped values t6 ~ 10p, t7 ~ 2p,
// t8 ~ 15p (p: the range's fraction of c/(2 * 8 MHz)) by sequential rounding; their mean
// t10 = (t6 + t7 + t8)/3 ~ 9p; and the pixel kept only when the unwrapped phases agree: the
// squared distance of 2*pi*(t6, t7, t8) from the line through (10, 2, 15) at most c^2, with c
// the dealias confidence (0.3490659 rad, its value for bright pixels). The spatial filters
// (bilateral, edge) and the amplitude thresholds, which need the camera's units, are left out:
// the comparison is of the unwrapping. Returns the radial range in metres (p * c/(2 * 8 MHz)),
// or NaN where libfreenect2 gives no depth. `measurements` are m(16 MHz), m(80 MHz),
// m(120 MHz) in the convention above (phase increasing with the time of flight).
double Libfreenect2Range(Complex m16, Complex m80, Complex m120);

}  // namespace transient::eval
