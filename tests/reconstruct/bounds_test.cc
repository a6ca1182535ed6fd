#include "transient/reconstruct/bounds.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "test_measures.h"
#include "transient/reconstruct/levinson.h"
#include "transient/reconstruct/mese.h"
#include "transient/reconstruct/pisarenko.h"

namespace transient {
namespace {

constexpr double kContainTolerance = 1e-9;  // relative to c_0
constexpr int kPhases = 64;

std::vector<double> Phases() {
  std::vector<double> phases(kPhases);
  for (int n = 0; n < kPhases; ++n) phases[n] = kTwoPi * (n + 0.37) / kPhases;
  return phases;
}

// A measure with m+1 atoms, one of them at `prescribed`, with moments c (thesis alg. B.2):
// the heaviest Dirac at `prescribed` that keeps C(c - w c(prescribed)) positive semi-definite
// is w = 1 / (b^* C^{-1} b); the singular remainder is exactly Pisarenko's m-sparse measure.
testing::SparseMeasure CanonicalMeasure(const std::vector<Complex>& c, double prescribed) {
  const int m = static_cast<int>(c.size()) - 1;
  const ToeplitzMatrix t = MakeToeplitz(c);
  SmallVector b(m + 1);
  for (int j = 0; j <= m; ++j) b(j) = std::polar(1.0, j * prescribed);
  const double w = 1.0 / b.dot(t.llt().solve(b)).real();
  std::vector<Complex> rest(c);
  for (int j = 0; j <= m; ++j) rest[j] -= w * b(j);
  PisarenkoEstimate estimate;
  EXPECT_TRUE(Pisarenko(rest, &estimate));
  testing::SparseMeasure measure;
  measure.phase = {prescribed};
  measure.weight = {w};
  for (int l = 0; l < estimate.count; ++l) {
    measure.phase.push_back(estimate.phase[l]);
    measure.weight.push_back(estimate.weight[l]);
  }
  measure.uniform = estimate.uniform;  // ~0 up to rounding
  return measure;
}

TEST(Bounds, PoissonKernelIntegratesToOne) {
  double sum = 0.0;
  for (int n = 0; n < 4096; ++n) sum += PoissonKernel(0.8, kTwoPi * n / 4096) * kTwoPi / 4096;
  EXPECT_NEAR(sum, 1.0, 1e-12);
}

TEST(Bounds, ContainTheSmoothedDensityOfEveryMeasureSharingTheMoments) {
  std::mt19937_64 rng(16);
  const auto phases = Phases();
  for (int m = 1; m <= 8; ++m) {
    for (double r : {0.3, 0.7, 0.93}) {
      // The ground truth: many returns plus a uniform part; the MESE and canonical
      // (m+1)-atom measures share its moments and must fall inside the same bounds.
      const auto truth = testing::RandomSparseMeasure(2 * m + 3, 0.02, 0.1, rng);
      const std::vector<Complex> c = truth.Moments(m);
      std::vector<double> lower(kPhases), upper(kPhases);
      ASSERT_TRUE(PoissonBounds(c, r, phases, lower, upper));
      std::vector<Complex> q(m + 1);
      ASSERT_TRUE(Levinson(c, q));
      const auto canonical = CanonicalMeasure(c, 1.234);
      const double tol = kContainTolerance * c[0].real();
      for (int n = 0; n < kPhases; ++n) {
        EXPECT_LE(lower[n], upper[n]);
        const double value = truth.PoissonSmoothed(r, phases[n]);
        EXPECT_GE(value, lower[n] - tol) << "m=" << m << " r=" << r << " n=" << n;
        EXPECT_LE(value, upper[n] + tol) << "m=" << m << " r=" << r << " n=" << n;
        const double other = canonical.PoissonSmoothed(r, phases[n]);
        EXPECT_GE(other, lower[n] - tol);
        EXPECT_LE(other, upper[n] + tol);
        // The MESE, smoothed by numerical convolution.
        double mese = 0.0;
        const int samples = 4096;
        for (int k = 0; k < samples; ++k) {
          const double psi = kTwoPi * k / samples;
          mese += PoissonKernel(r, phases[n] - psi) * MeseDensity(q, psi) * kTwoPi / samples;
        }
        EXPECT_GE(mese, lower[n] - 1e-6 * c[0].real());
        EXPECT_LE(mese, upper[n] + 1e-6 * c[0].real());
      }
    }
  }
}

TEST(Bounds, AreSharpCanonicalMeasuresTouchThem) {
  // The bounds are attained by the (m+1)-atom measures sharing the moments; sweeping the
  // prescribed atom traces all of them, so their extremes must reach both bounds.
  std::mt19937_64 rng(17);
  for (int m : {1, 3, 5}) {
    const auto truth = testing::RandomSparseMeasure(m + 4, 0.1, 0.2, rng);
    const std::vector<Complex> c = truth.Moments(m);
    const double r = 0.8;
    for (double phi : {0.5, 2.0, 4.4}) {
      std::vector<double> phases = {phi}, lower(1), upper(1);
      ASSERT_TRUE(PoissonBounds(c, r, phases, lower, upper));
      // The smoothed value as a function of the prescribed atom's phase: its extremes from a
      // sweep of 1000 phases, each refined by golden-section search within its neighbours
      // (as close as a sweep of 20000 phases came, at a twentieth of the evaluations).
      const auto smoothed = [&](double atom) {
        return CanonicalMeasure(c, atom).PoissonSmoothed(r, phi);
      };
      constexpr int kSweep = 1000;
      const double step = kTwoPi / kSweep;
      int lowest = 0, highest = 0;
      std::vector<double> sweep(kSweep);
      for (int k = 0; k < kSweep; ++k) {
        sweep[k] = smoothed(step * k);
        if (sweep[k] < sweep[lowest]) lowest = k;
        if (sweep[k] > sweep[highest]) highest = k;
      }
      const auto refine = [&](int k, double sign) {  // the extreme of sign * value near k
        double a = step * (k - 1), b = step * (k + 1);
        const double golden = (std::sqrt(5.0) - 1.0) / 2.0;
        for (int i = 0; i < 40; ++i) {
          const double x1 = b - golden * (b - a), x2 = a + golden * (b - a);
          if (sign * smoothed(x1) > sign * smoothed(x2)) {
            b = x2;
          } else {
            a = x1;
          }
        }
        return std::max(sign * sweep[k], sign * smoothed(0.5 * (a + b))) * sign;
      };
      const double smallest = refine(lowest, -1.0), largest = refine(highest, 1.0);
      const double scale = upper[0] - lower[0];
      EXPECT_NEAR(largest, upper[0], 1e-4 * scale) << "m=" << m << " phi=" << phi;
      EXPECT_NEAR(smallest, lower[0], 1e-4 * scale) << "m=" << m << " phi=" << phi;
    }
  }
}

TEST(Bounds, PinchOntoANearlySparseTruth) {
  // An m-sparse measure is the only one with its moments (thesis prop. 2.13), so as its
  // uniform part vanishes the bounds must close on its smoothed density.
  std::mt19937_64 rng(27);
  const auto phases = Phases();
  for (int m : {2, 4, 8}) {
    auto truth = testing::RandomSparseMeasure(m, 0.3, 0.0, rng);
    double previous_width = 1e300;
    for (double uniform : {1e-2, 1e-4, 1e-6}) {
      truth.uniform = uniform;
      std::vector<double> lower(kPhases), upper(kPhases);
      ASSERT_TRUE(PoissonBounds(truth.Moments(m), 0.5, phases, lower, upper));
      double width = 0.0;
      for (int n = 0; n < kPhases; ++n) {
        const double value = truth.PoissonSmoothed(0.5, phases[n]);
        EXPECT_GE(value, lower[n] - 1e-7 * value);
        EXPECT_LE(value, upper[n] + 1e-7 * value);
        width = std::max(width, (upper[n] - lower[n]) / value);
      }
      EXPECT_LT(width, 0.5 * previous_width) << "m=" << m << " uniform=" << uniform;
      previous_width = width;
    }
    EXPECT_LT(previous_width, 1e-3) << "m=" << m;
  }
}

TEST(Bounds, ReduceToThePoissonKernelRangeForASingleMoment) {
  // With only c_0 known, the smoothed density lies between the kernel's extremes.
  const std::vector<Complex> c = {2.0, 0.0};
  const double r = 0.6;
  std::vector<double> phases = {1.0}, lower(1), upper(1);
  ASSERT_TRUE(PoissonBounds(c, r, phases, lower, upper));
  // Not exactly the m = 0 case (c_1 = 0 is known), so the bounds are tighter than that.
  EXPECT_GE(lower[0], 2.0 * (1 - r) / (1 + r) / kTwoPi - 1e-12);
  EXPECT_LE(upper[0], 2.0 * (1 + r) / (1 - r) / kTwoPi + 1e-12);
  EXPECT_LT(lower[0], 2.0 / kTwoPi);
  EXPECT_GT(upper[0], 2.0 / kTwoPi);
}

TEST(Bounds, RefuseAnIndefiniteToeplitzMatrix) {
  const std::vector<Complex> c = {1.0, 1.5};
  std::vector<double> phases = {1.0}, lower(1), upper(1);
  EXPECT_FALSE(PoissonBounds(c, 0.5, phases, lower, upper));
}

}  // namespace
}  // namespace transient
