// Range estimation (thesis §8.4.3): the first peak of the MESE density, or the first
// Pisarenko return, above a threshold relative to the strongest one.
#pragma once

#include <span>

#include "transient/reconstruct/moments.h"
#include "transient/reconstruct/pisarenko.h"

namespace transient {

// Phase in [0, 2*pi) of the first local maximum of D(phi), scanning from phi = 0, whose
// density is at least `threshold` times the highest density. Peaks are found on a grid of
// `search_bins` phases and refined by Newton's method on the derivative of the denominator
// series (sub-bin accuracy). Returns NaN when there is no local maximum (a flat density).
double MeseFirstPeakPhase(std::span<const Complex> q, double threshold, int search_bins);

// Phase of the first return (ascending phase) with weight >= threshold * largest weight;
// NaN when there is no return. Its index is written to `index` when non-null (-1 if none).
double PisarenkoFirstReturnPhase(const PisarenkoEstimate& estimate, double threshold,
                                 int* index = nullptr);

}  // namespace transient
