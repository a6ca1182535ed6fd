// Known measures on the circle for the reconstruction tests.
#include "test_measures.h"

#include <cmath>

#include "transient/reconstruct/bounds.h"

namespace transient::testing {

std::vector<Complex> SparseMeasure::Moments(int m) const {
  std::vector<Complex> c(m + 1);
  DiracMoments(phase, weight, c);
  c[0] += uniform;
  return c;
}

double SparseMeasure::PoissonSmoothed(double r, double phi) const {
  double sum = uniform / kTwoPi;  // P_r integrates to one
  for (size_t l = 0; l < phase.size(); ++l) sum += weight[l] * PoissonKernel(r, phi - phase[l]);
  return sum;
}

std::vector<Complex> MomentSetTrial(int m, int count, int trial, std::mt19937_64& rng,
                                    double* sigma) {
  const double uniform = (trial % 4 == 0) ? 0.3 : 0.0;
  std::vector<Complex> c = RandomSparseMeasure(count, 0.1, uniform, rng).Moments(m);
  *sigma = (trial % 4 == 1) ? 0.0 : 0.01 * (1 + trial % 5);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int j = 1; j <= m; ++j) c[j] += *sigma * c[0].real() * Complex(noise(rng), noise(rng));
  return c;
}

SparseMeasure RandomSparseMeasure(int count, double min_separation, double uniform,
                                  std::mt19937_64& rng) {
  std::uniform_real_distribution<double> phase_dist(0.0, kTwoPi);
  std::uniform_real_distribution<double> weight_dist(0.2, 1.0);
  SparseMeasure measure;
  measure.uniform = uniform;
  while (static_cast<int>(measure.phase.size()) < count) {
    const double candidate = phase_dist(rng);
    bool far = true;
    for (double p : measure.phase) {
      const double d = std::abs(WrapPhase(candidate - p + std::numbers::pi) - std::numbers::pi);
      far = far && d >= min_separation;
    }
    if (!far) continue;
    measure.phase.push_back(candidate);
    measure.weight.push_back(weight_dist(rng));
  }
  return measure;
}

std::vector<Complex> DensityMoments(const std::function<double(double)>& density, int m,
                                    int samples) {
  std::vector<Complex> c(m + 1, 0.0);
  const double h = kTwoPi / samples;
  for (int n = 0; n < samples; ++n) {
    const double phi = n * h;
    const double d = density(phi) * h;
    for (int j = 0; j <= m; ++j) c[j] += d * std::polar(1.0, j * phi);
  }
  c[0] = c[0].real();
  return c;
}

double ExponentiallyModifiedGaussian(double phase, double mu, double sigma, double lambda) {
  // Sum over a few periods so the wrapped density is smooth and periodic.
  double sum = 0.0;
  for (int k = -2; k <= 2; ++k) {
    const double x = phase + k * kTwoPi;
    const double arg = (mu + lambda * sigma * sigma - x) / (std::sqrt(2.0) * sigma);
    sum += 0.5 * lambda * std::exp(0.5 * lambda * (2.0 * mu + lambda * sigma * sigma - 2.0 * x)) *
           std::erfc(arg);
  }
  return sum;
}

}  // namespace transient::testing
