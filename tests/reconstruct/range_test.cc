#include "transient/reconstruct/range.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "test_measures.h"
#include "transient/reconstruct/biasing.h"
#include "transient/reconstruct/levinson.h"
#include "transient/reconstruct/mese.h"

namespace transient {
namespace {

constexpr double kFrequency = 23e6;  // thesis §8.5

std::vector<Complex> Solve(std::vector<Complex> c, double epsilon) {
  Bias(c, epsilon, BiasMode::kRaiseZeroth);
  std::vector<Complex> q(c.size());
  EXPECT_TRUE(Levinson(c, q));
  return q;
}

TEST(Range, PhaseAndRangeConvert) {
  // One full period of phase is half the modulation wavelength: c / (2 f).
  EXPECT_NEAR(PhaseToRange(kTwoPi, kFrequency), kSpeedOfLight / (2 * kFrequency), 1e-9);
  EXPECT_NEAR(RangeToPhase(PhaseToRange(1.234, kFrequency), kFrequency), 1.234, 1e-15);
}

TEST(Range, SparseResponsesGiveTheFirstReturn) {
  std::mt19937_64 rng(19);
  for (int m : {2, 3, 4, 8}) {
    for (int trial = 0; trial < 20; ++trial) {
      // m/2 returns at least 0.6 rad apart, the first the strongest or not.
      const auto truth = testing::RandomSparseMeasure(std::max(1, m / 2), 0.6, 0.0, rng);
      const std::vector<Complex> q = Solve(truth.Moments(m), 4e-3);
      double first = kTwoPi;
      for (size_t l = 0; l < truth.phase.size(); ++l) {
        // The threshold is relative to the highest peak; our weights are within 5x.
        first = std::min(first, truth.phase[l]);
      }
      const double phase = MeseFirstPeakPhase(q, 0.05, 512);
      // Biasing with eps = 4e-3 pulls peaks slightly towards each other; 1 mrad is 1 mm here.
      EXPECT_NEAR(phase, first, 2e-3 * 8 / m) << "m=" << m << " trial=" << trial;
    }
  }
}

TEST(Range, SinglePeakIsFoundToSubBinAccuracy) {
  testing::SparseMeasure truth;
  truth.phase = {2.0 + 0.3 * kTwoPi / 64};  // between two of 64 grid bins
  truth.weight = {1.0};
  const std::vector<Complex> q = Solve(truth.Moments(3), 4e-3);
  // A single return with a uniform bias is symmetric: the peak is exactly at the return.
  EXPECT_NEAR(MeseFirstPeakPhase(q, 0.1, 64), truth.phase[0], 1e-9);
}

TEST(Range, ExponentiallyModifiedGaussianResponseGivesTheFirstReturn) {
  // A sharp direct return and a later, broad indirect one (a diffuse corner's pixel).
  for (int m : {3, 4, 8}) {
    const double onset = 1.2;
    auto density = [&](double phi) {
      return testing::ExponentiallyModifiedGaussian(phi, onset, 0.03, 20.0) +
             0.5 * testing::ExponentiallyModifiedGaussian(phi, 2.6, 0.3, 2.0);
    };
    const std::vector<Complex> c = testing::DensityMoments(density, m, 1 << 14);
    // The mode of the first EMG: it lies just after the onset.
    double mode = onset, best = 0.0;
    for (int k = 0; k < 20000; ++k) {
      const double phi = onset - 0.2 + 0.4 * k / 20000;
      const double v = testing::ExponentiallyModifiedGaussian(phi, onset, 0.03, 20.0);
      if (v > best) best = v, mode = phi;
    }
    const double phase = MeseFirstPeakPhase(Solve(c, 4e-3), 0.1, 512);
    // m = 3 resolves the first return to within a few degrees; more moments, less bias.
    const double tolerance = m == 3 ? 0.1 : 0.05;
    EXPECT_NEAR(phase, mode, tolerance) << "m = " << m;
    EXPECT_LT(phase, 2.0) << "the indirect return must not be taken for the first";
  }
}

TEST(Range, AWeakEarlyReturnCountsByItsLight) {
  // Three returns at m = 4: the first, with 0.4 of the others' light, is resolved less sharply
  // than they are, so its peak is below a tenth of the highest; its light is not.
  testing::SparseMeasure truth;
  truth.phase = {1.0, 2.0, 4.0};
  truth.weight = {0.4, 1.0, 1.0};
  const std::vector<Complex> q = Solve(truth.Moments(4), 4e-3);
  const double phase = MeseFirstPeakPhase(q, 0.1, 16 * 5);
  EXPECT_NEAR(phase, truth.phase[0], 5e-3);  // 5 mm at 23 MHz
  // The density at the later returns is at most their peaks'.
  const double highest = std::max(MeseDensity(q, truth.phase[1]), MeseDensity(q, truth.phase[2]));
  EXPECT_LT(MeseDensity(q, phase), 0.1 * highest) << "the peak's height alone would not pass";
}

// Peaks on a grid of 64 bins: a low early one at bin 10 and the highest at bin 30.
std::vector<MesePeak> TwoPeaks(double early_light) {
  return {{10 * kTwoPi / 64, 50.0, early_light, 10}, {30 * kTwoPi / 64, 1.0, 1.0, 30}};
}
std::vector<double> Grid(double valley_before, double valley_after) {
  std::vector<double> r(64, 100.0);
  r[10] = 50.0;
  r[30] = 1.0;
  r[20] = valley_after;   // between the early peak and the highest
  r[50] = valley_before;  // between the highest and the early peak, across the wrap
  return r;
}

TEST(Range, APeakCountsByItsLightOnlyWhereItStandsApart) {
  const std::vector<MesePeak> peaks = TwoPeaks(0.2);
  const double early = peaks[0].phase, highest = peaks[1].phase;
  // Its density (1/50 of the highest) is below the threshold; its light is 0.2 of the brightest,
  // and the density falls below a tenth of its height (denominator above 500) on both sides.
  EXPECT_EQ(MeseFirstReturn(peaks, 0.1, Grid(600.0, 600.0)), early);
  // A shallow dip on either side: a split peak or a shoulder, not a return of its own.
  EXPECT_EQ(MeseFirstReturn(peaks, 0.1, Grid(600.0, 400.0)), highest);
  EXPECT_EQ(MeseFirstReturn(peaks, 0.1, Grid(400.0, 600.0)), highest);
  // Too little light.
  EXPECT_EQ(MeseFirstReturn(TwoPeaks(0.05), 0.1, Grid(600.0, 600.0)), highest);
  // A high enough peak passes by its height, whatever its light.
  std::vector<MesePeak> high = TwoPeaks(0.0);
  high[0].denominator = 5.0;
  EXPECT_EQ(MeseFirstReturn(high, 0.1, Grid(6.0, 6.0)), early);
  EXPECT_TRUE(std::isnan(MeseFirstReturn({}, 0.1, Grid(600.0, 600.0))));
  // Bins outside the grid (a caller's mistake): no valleys read, the choice by height alone.
  std::vector<MesePeak> outside = peaks;
  outside[1].bin = 64;
  EXPECT_EQ(MeseFirstReturn(outside, 0.1, Grid(600.0, 600.0)), highest);
  outside[1].bin = -1;
  EXPECT_EQ(MeseFirstReturn(outside, 0.1, Grid(600.0, 600.0)), highest);
  EXPECT_EQ(MeseFirstReturn(peaks, 0.1, {}), highest);
  // Peaks without light (a flat top) never pass by it, even when none has any.
  std::vector<MesePeak> dark = TwoPeaks(0.0);
  dark[1].light = 0.0;
  EXPECT_EQ(MeseFirstReturn(dark, 0.1, Grid(600.0, 600.0)), highest);
}

TEST(Range, PeakLightIsItsPolesIntegralAboveTheFloor) {
  // r(phi) = A - B cos(phi) with A - B = r, B = r'': 1 / sqrt(A^2 - B^2) - 1 / (A + B).
  const double r = 0.01, r2 = 3.0, a = r + r2, b = r2;
  EXPECT_NEAR(MesePeakLight(r, r2), 1.0 / std::sqrt(a * a - b * b) - 1.0 / (a + b), 1e-12);
  // Broader (a smaller r''), as high: more light. A flat top (r'' = 0): none above the floor.
  EXPECT_GT(MesePeakLight(r, 1.0), MesePeakLight(r, 3.0));
  EXPECT_NEAR(MesePeakLight(r, 0.0), 0.0, 1e-9);
  EXPECT_NEAR(MesePeakLight(r, std::nan("")), 0.0, 1e-9);
}

TEST(Range, ReturnAtTheCameraIsFirstOnEitherSideOfTheWrap) {
  // A strong return at phi = 0 lands a hair below 2*pi after biasing; it must still be first.
  for (double at : {1e-6, 0.0, kTwoPi - 1e-6}) {
    testing::SparseMeasure truth;
    truth.phase = {at, 3.0};
    truth.weight = {1.0, 0.8};
    const std::vector<Complex> q = Solve(truth.Moments(8), 4e-3);
    const double phase = MeseFirstPeakPhase(q, 0.1, 512);
    EXPECT_NEAR(phase, at > std::numbers::pi ? at - kTwoPi : at, 1e-3) << "return at " << at;
    PisarenkoEstimate estimate;
    estimate.count = 2;
    estimate.phase = {2.0, kTwoPi - 1e-7};  // sorted in [0, 2*pi)
    estimate.weight = {0.5, 1.0};
    EXPECT_NEAR(PisarenkoFirstReturnPhase(estimate, 0.1), -1e-7, 1e-12);
  }
}

TEST(Range, SharpPeaksOfBarelyBiasedPixelsAreFound) {
  // With eps = 1e-6 the denominator's minimum is ~1e-12 of its mean: the expanded cosine
  // series cancels to noise there, direct evaluation of |p|^2 does not.
  std::mt19937_64 rng(26);
  for (int m : {3, 8, 16}) {
    for (int trial = 0; trial < 50; ++trial) {
      std::uniform_real_distribution<double> phase(0.1, 6.0);
      testing::SparseMeasure truth;
      truth.phase = {phase(rng)};
      truth.weight = {1.0};
      const std::vector<Complex> q = Solve(truth.Moments(m), 1e-6);
      EXPECT_NEAR(MeseFirstPeakPhase(q, 0.1, 512), truth.phase[0], 1e-8) << "m = " << m;
    }
  }
}

TEST(Range, FlatDensityHasNoPeak) {
  const std::vector<Complex> q = Solve({1.0, 0.0, 0.0, 0.0}, 4e-3);
  EXPECT_TRUE(std::isnan(MeseFirstPeakPhase(q, 0.1, 128)));
}

TEST(Range, ThresholdSkipsWeakEarlyPeaks) {
  testing::SparseMeasure truth;
  truth.phase = {1.0, 3.0};
  truth.weight = {0.05, 1.0};
  const std::vector<Complex> q = Solve(truth.Moments(6), 4e-3);
  EXPECT_NEAR(MeseFirstPeakPhase(q, 0.0, 512), 1.0, 0.01);
  EXPECT_NEAR(MeseFirstPeakPhase(q, 0.9, 512), 3.0, 0.01);
}

TEST(Range, PisarenkoFirstReturnAboveThreshold) {
  PisarenkoEstimate estimate;
  estimate.count = 3;
  estimate.phase = {0.5, 1.0, 2.0};
  estimate.weight = {0.01, 1.0, 0.5};
  int index = -2;
  EXPECT_EQ(PisarenkoFirstReturnPhase(estimate, 0.1, &index), 1.0);
  EXPECT_EQ(index, 1);
  EXPECT_EQ(PisarenkoFirstReturnPhase(estimate, 0.0), 0.5);
  estimate.count = 0;
  EXPECT_TRUE(std::isnan(PisarenkoFirstReturnPhase(estimate, 0.1, &index)));
  EXPECT_EQ(index, -1);
}

}  // namespace
}  // namespace transient
