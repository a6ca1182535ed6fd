// Known measures on the circle and their moments, shared by the reconstruction tests.
#pragma once

#include <functional>
#include <random>
#include <vector>

#include "transient/reconstruct/moments.h"

namespace transient::testing {

// A sum of Dirac deltas plus a uniform component of total mass `uniform`.
struct SparseMeasure {
  std::vector<double> phase;   // radians in [0, 2*pi)
  std::vector<double> weight;  // > 0
  double uniform = 0.0;

  // c_0..c_m of the measure.
  std::vector<Complex> Moments(int m) const;
  // (P_r * F)(phi).
  double PoissonSmoothed(double r, double phi) const;
};

// `count` returns with phases at least `min_separation` apart (cyclically) and weights in
// [0.2, 1], plus a uniform component of the given mass.
SparseMeasure RandomSparseMeasure(int count, double min_separation, double uniform,
                                  std::mt19937_64& rng);

// Moments c_0..c_m inside, on and past the boundary of the moment set, by `trial` (a cycle of
// 4 x 5): those of RandomSparseMeasure(count, 0.1, uniform) with a uniform mass of 0.3 in every
// fourth trial; c_1..c_m with complex Gaussian noise of 1-5 % of c_0 per component, except in
// trials 1, 5, 9, ... (noise-free: on the boundary where count <= m and there is no uniform
// part). *sigma is the noise's share of c_0 (0 when noise-free).
std::vector<Complex> MomentSetTrial(int m, int count, int trial, std::mt19937_64& rng,
                                    double* sigma);

// Moments c_0..c_m of a density on [0, 2*pi) by the trapezoidal rule on `samples` points
// (exponentially accurate for smooth periodic densities).
std::vector<Complex> DensityMoments(const std::function<double(double)>& density, int m,
                                    int samples);

// Exponentially modified Gaussian of unit mass in phase: onset `mu`, spread `sigma`, decay
// `lambda` (1/radian), wrapped onto the circle.
double ExponentiallyModifiedGaussian(double phase, double mu, double sigma, double lambda);

}  // namespace transient::testing
