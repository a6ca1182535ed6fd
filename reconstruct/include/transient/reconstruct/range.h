// Range estimation (thesis §8.4.3): the first peak of the MESE density, or the first
// Pisarenko return, above a threshold relative to the strongest one.
#pragma once

#include <span>

#include "transient/reconstruct/moments.h"
#include "transient/reconstruct/pisarenko.h"

namespace transient {

// A return at the camera (phi = 0) is measured, with noise or bias, on either side of the
// wrap: phases within kWrapGuard below 2*pi count as slightly negative when returns are
// ordered, so such a return is the first one, not the last. 2*pi/1024 is 6.4 mm at 23 MHz.
inline constexpr double kWrapGuard = kTwoPi / 1024;

// The phase used to order returns: wrapped into [-kWrapGuard, 2*pi - kWrapGuard).
inline double OrderingPhase(double phase) {
  const double wrapped = WrapPhase(phase);
  return wrapped >= kTwoPi - kWrapGuard ? wrapped - kTwoPi : wrapped;
}

// Phase of the first return of D(phi), in [-kWrapGuard, 2*pi - kWrapGuard): the first local
// maximum (a peak) whose density is at least `threshold` times the highest peak's, or that
// carries at least `threshold` times the light of the brightest peak and stands apart, the
// density falling to `threshold` times its height or below on both sides before the
// neighbouring peaks (MeseFirstReturn). Peaks are found on a grid of `search_bins` phases and
// refined by Newton's method on the derivative of the denominator (sub-bin accuracy). Returns
// NaN when there is no local maximum (a flat density).
double MeseFirstPeakPhase(std::span<const Complex> q, double threshold, int search_bins);

// The same from a grid computed elsewhere: r[n] = |sum_j conj(q_j) exp(i j phi_n)|^2 at
// phi_n = 2*pi*n/r.size() (any evaluation accurate to ~1e-9 relative will do; minima are then
// refined from q).
double MeseFirstPeakFromGrid(std::span<const Complex> q, double threshold,
                             std::span<const double> r);
// The same with the denominator series `a` of q (MeseDenominatorSeries) already computed.
double MeseFirstPeakFromGrid(std::span<const Complex> q, std::span<const Complex> a,
                             double threshold, std::span<const double> r);

// A peak of D: its phase (as OrderingPhase), the denominator |p|^2 there (D = q_0 / (2 pi
// |p|^2)), its light (MesePeakLight) and the grid bin it was refined from.
struct MesePeak {
  double phase, denominator, light;
  int bin;
};

// The light of a peak per unit q_0, from the denominator r and its second derivative r'' there:
// the integral of its pole's term of D (the shape of one root's partial fraction, thesis eq.
// 8.9) above that term's floor, 1 / sqrt(r (r + 2 r'')) - 1 / (r + 2 r''). A peak's height
// grows with its sharpness as well as its light; this counts the light.
double MesePeakLight(double denominator, double second_derivative);

// The rule of MeseFirstPeakPhase over `peaks` (in the order of their bins) found on the grid
// `r`, whose values between the peaks give the valleys. A weak early return that the moments
// resolve less sharply than a later one has a low peak but its light; a peak split off by
// noise, or a broad lobe, does not stand apart from its neighbour (transient eval: docs/eval.md).
// A peak whose bin, or a neighbour's, lies outside `r` passes by its height only.
double MeseFirstReturn(std::span<const MesePeak> peaks, double threshold,
                       std::span<const double> r);

// Phase (as OrderingPhase) of the first return with weight >= threshold * largest weight;
// NaN when there is no return. Its index is written to `index` when non-null (-1 if none).
double PisarenkoFirstReturnPhase(const PisarenkoEstimate& estimate, double threshold,
                                 int* index = nullptr);

}  // namespace transient
