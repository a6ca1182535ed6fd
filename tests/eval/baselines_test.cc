#include "tools/eval/baselines.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <thread>
#include <vector>

#include "tests/support/status_matchers.h"

namespace transient::eval {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

constexpr double kTwoPi = 2.0 * std::numbers::pi;

// Frequencies of thesis fig. 8.12: 11 MHz harmonics for Godbaz and SPUMIC, 23/46/69 for SRA.
constexpr double kBaseHz = 11e6;
constexpr double kBasePeriodS = 1.0 / kBaseHz;
constexpr double kSraHz[] = {23e6, 46e6, 69e6};
constexpr double kSraPeriodS = 1.0 / 23e6;

// A few ulps of a phase of order 2*pi, as a fraction of the period.
constexpr double kPhaseExact = 1e-14;
// Closed-form and SVD Prony on noise-free data: rounding (1e-16) amplified by the 2x2 or
// Hankel system's conditioning, which for the returns below (at least 0.05 periods apart,
// weights >= 0.2) stays under 1e4. Relative to the period (times) or the largest weight.
constexpr double kPronyExact = 1e-9;

struct Truth {
  std::vector<double> time_s;
  std::vector<double> weight;
};

std::vector<Complex> Measure(const Truth& truth, std::span<const double> frequencies_hz) {
  std::vector<Complex> m;
  for (double f : frequencies_hz) {
    Complex sum = 0.0;
    for (size_t l = 0; l < truth.time_s.size(); ++l) {
      sum += truth.weight[l] * std::polar(1.0, kTwoPi * f * truth.time_s[l]);
    }
    m.push_back(sum);
  }
  return m;
}

std::vector<double> Harmonics(double base_hz, int count) {
  std::vector<double> f;
  for (int k = 1; k <= count; ++k) f.push_back(k * base_hz);
  return f;
}

double CircularDistance(double a, double b, double period) {
  const double d = std::fmod(std::abs(a - b), period);
  return std::min(d, period - d);
}

// The invariants of the header: sorted, in [0, period), weights finite and > 0.
void ExpectWellFormed(const SparseReturns& r, double period_s) {
  ASSERT_EQ(r.time_of_flight_s.size(), r.weight.size());
  EXPECT_TRUE(std::is_sorted(r.time_of_flight_s.begin(), r.time_of_flight_s.end()));
  for (size_t l = 0; l < r.weight.size(); ++l) {
    EXPECT_GE(r.time_of_flight_s[l], 0.0);
    EXPECT_LT(r.time_of_flight_s[l], period_s);
    EXPECT_TRUE(std::isfinite(r.weight[l]));
    EXPECT_GT(r.weight[l], 0.0);
  }
}

// Each true return has an estimate within `time_tolerance_s` (cyclically) and
// `weight_tolerance`, and there are as many estimates as true returns.
void ExpectRecovers(const SparseReturns& r, const Truth& truth, double period_s,
                    double time_tolerance_s, double weight_tolerance) {
  ExpectWellFormed(r, period_s);
  ASSERT_EQ(r.time_of_flight_s.size(), truth.time_s.size());
  for (size_t l = 0; l < truth.time_s.size(); ++l) {
    size_t nearest = 0;
    for (size_t e = 1; e < r.time_of_flight_s.size(); ++e) {
      if (CircularDistance(r.time_of_flight_s[e], truth.time_s[l], period_s) <
          CircularDistance(r.time_of_flight_s[nearest], truth.time_s[l], period_s)) {
        nearest = e;
      }
    }
    EXPECT_LE(CircularDistance(r.time_of_flight_s[nearest], truth.time_s[l], period_s),
              time_tolerance_s)
        << "return " << l << " at " << truth.time_s[l];
    EXPECT_NEAR(r.weight[nearest], truth.weight[l], weight_tolerance) << "return " << l;
  }
}

// --- SingleFrequencyPhase -------------------------------------------------------------

TEST(SingleFrequencyPhase, RecoversOneDiracExactly) {
  const double f = 23e6;
  const Truth truth{{17.3e-9}, {0.7}};
  const SparseReturns r = SingleFrequencyPhase(Measure(truth, {&f, 1})[0], f);
  ExpectRecovers(r, truth, 1.0 / f, kPhaseExact / f, 1e-15);
}

TEST(SingleFrequencyPhase, WrapsNegativePhasesIntoThePeriod) {
  const double f = 23e6;
  const SparseReturns r = SingleFrequencyPhase(std::polar(2.0, -0.5), f);
  ASSERT_EQ(r.time_of_flight_s.size(), 1u);
  EXPECT_NEAR(r.time_of_flight_s[0], (kTwoPi - 0.5) / (kTwoPi * f), kPhaseExact / f);
  EXPECT_DOUBLE_EQ(r.weight[0], 2.0);
}

TEST(SingleFrequencyPhase, ZeroOrInvalidInputGivesNoReturn) {
  EXPECT_TRUE(SingleFrequencyPhase(Complex(0.0), 23e6).weight.empty());
  EXPECT_TRUE(SingleFrequencyPhase(Complex(std::nan(""), 1.0), 23e6).weight.empty());
  EXPECT_TRUE(SingleFrequencyPhase(Complex(1.0), 0.0).weight.empty());
  EXPECT_TRUE(SingleFrequencyPhase(Complex(1.0), -23e6).weight.empty());
}

// --- GodbazTwoDirac --------------------------------------------------------------------

TEST(GodbazTwoDirac, IsExactOnTwoNoiseFreeDiracs) {
  const std::vector<double> f = Harmonics(kBaseHz, 4);
  const Truth cases[] = {
      {{10e-9, 40e-9}, {1.0, 0.5}},                        // well apart
      {{20e-9, 0.3 * kBasePeriodS}, {0.2, 1.0}},           // weaker first
      {{30e-9, 30e-9 + 0.05 * kBasePeriodS}, {1.0, 0.8}},  // 0.05 periods apart
      {{5e-9, kBasePeriodS * (1.0 - 1e-6)}, {1.0, 0.6}},   // one just below the wrap
      {{0.0, 0.5 * kBasePeriodS}, {0.9, 0.9}},             // one at zero, equal weights
  };
  for (const Truth& truth : cases) {
    absl::StatusOr<SparseReturns> r = GodbazTwoDirac(Measure(truth, f), kBaseHz);
    ASSERT_THAT(r.status(), IsOk());
    ExpectRecovers(*r, truth, kBasePeriodS, kPronyExact * kBasePeriodS, kPronyExact);
  }
}

TEST(GodbazTwoDirac, GivesOneReturnForOneDirac) {
  const Truth truth{{33e-9}, {0.8}};
  absl::StatusOr<SparseReturns> r = GodbazTwoDirac(Measure(truth, Harmonics(kBaseHz, 4)), kBaseHz);
  ASSERT_THAT(r.status(), IsOk());
  ExpectRecovers(*r, truth, kBasePeriodS, kPronyExact * kBasePeriodS, kPronyExact);
}

TEST(GodbazTwoDirac, GivesNoReturnForZeroInput) {
  const std::vector<Complex> zero(4, Complex(0.0));
  absl::StatusOr<SparseReturns> r = GodbazTwoDirac(zero, kBaseHz);
  ASSERT_THAT(r.status(), IsOk());
  EXPECT_TRUE(r->weight.empty());
}

TEST(GodbazTwoDirac, IsScaleInvariant) {  // normalization keeps huge inputs finite
  const Truth truth{{10e-9, 40e-9}, {1e300, 0.5e300}};
  absl::StatusOr<SparseReturns> r = GodbazTwoDirac(Measure(truth, Harmonics(kBaseHz, 4)), kBaseHz);
  ASSERT_THAT(r.status(), IsOk());
  ExpectRecovers(*r, truth, kBasePeriodS, kPronyExact * kBasePeriodS, kPronyExact * 1e300);
}

TEST(GodbazTwoDirac, RejectsBadInput) {
  const std::vector<Complex> three(3, Complex(1.0));
  EXPECT_THAT(GodbazTwoDirac(three, kBaseHz).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("exactly 4")));
  std::vector<Complex> four(4, Complex(1.0));
  EXPECT_THAT(GodbazTwoDirac(four, 0.0).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("base_frequency_hz")));
  four[2] = Complex(std::numeric_limits<double>::infinity(), 0.0);
  EXPECT_THAT(GodbazTwoDirac(four, kBaseHz).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("measurement 2")));
}

// --- Spumic --------------------------------------------------------------------------

TEST(Spumic, IsExactOnTwoNoiseFreeDiracsFromSixMeasurements) {
  const Truth truth{{12e-9, 12e-9 + 0.2 * kBasePeriodS}, {1.0, 0.4}};
  const std::vector<Complex> m = Measure(truth, Harmonics(kBaseHz, 6));
  for (int cadzow_iterations : {0, 3}) {
    absl::StatusOr<SparseReturns> r = Spumic(m, kBaseHz, 2, cadzow_iterations);
    ASSERT_THAT(r.status(), IsOk());
    ExpectRecovers(*r, truth, kBasePeriodS, kPronyExact * kBasePeriodS, kPronyExact);
  }
}

TEST(Spumic, IsExactOnThreeDiracs) {
  const Truth truth{{3e-9, 35e-9, 70e-9}, {0.5, 1.0, 0.3}};
  absl::StatusOr<SparseReturns> r = Spumic(Measure(truth, Harmonics(kBaseHz, 6)), kBaseHz, 3);
  ASSERT_THAT(r.status(), IsOk());
  ExpectRecovers(*r, truth, kBasePeriodS, kPronyExact * kBasePeriodS, kPronyExact);
}

TEST(Spumic, StaysCloseWithSmallNoise) {
  // Gaussian noise of sigma = 1e-3 per real component (SNR ~1000:1 for the stronger return)
  // moves the returns by ~sigma / (weight * sqrt(K) * 2 pi) periods, ~1e-4; 2e-3 periods and
  // 0.02 in weight leave a margin of ~10 for these well separated returns.
  const Truth truth{{12e-9, 12e-9 + 0.3 * kBasePeriodS}, {1.0, 0.6}};
  std::mt19937_64 rng(6);
  std::normal_distribution<double> noise(0.0, 1e-3);
  for (int trial = 0; trial < 5; ++trial) {
    std::vector<Complex> m = Measure(truth, Harmonics(kBaseHz, 6));
    for (Complex& value : m) value += Complex(noise(rng), noise(rng));
    for (int cadzow_iterations : {0, 3}) {
      absl::StatusOr<SparseReturns> r = Spumic(m, kBaseHz, 2, cadzow_iterations);
      ASSERT_THAT(r.status(), IsOk());
      ExpectRecovers(*r, truth, kBasePeriodS, 2e-3 * kBasePeriodS, 0.02);
    }
  }
}

TEST(Spumic, DropsTheSpuriousReturnOfAnOverModelledDirac) {
  const Truth truth{{50e-9}, {0.9}};
  absl::StatusOr<SparseReturns> r = Spumic(Measure(truth, Harmonics(kBaseHz, 6)), kBaseHz, 2);
  ASSERT_THAT(r.status(), IsOk());
  ExpectRecovers(*r, truth, kBasePeriodS, kPronyExact * kBasePeriodS, kPronyExact);
}

TEST(Spumic, RejectsBadInput) {
  const std::vector<Complex> three(3, Complex(1.0));
  EXPECT_THAT(Spumic(three, kBaseHz, 2).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("K >= 2 * returns")));
  EXPECT_THAT(Spumic(three, kBaseHz, 0).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("returns = 0")));
  const std::vector<Complex> six(6, Complex(1.0));
  EXPECT_THAT(Spumic(six, kBaseHz, 2, -1).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("cadzow_iterations")));
  EXPECT_THAT(Spumic(six, std::nan("")).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("base_frequency_hz")));
}

// --- Sra -----------------------------------------------------------------------------

constexpr int kGridBins = 512;
constexpr double kBinS = kSraPeriodS / kGridBins;
constexpr double kEpsilon = 0.05;
// GLPK's simplex works to ~1e-9 relative feasibility; a margin for the weight bounds.
constexpr double kLpTolerance = 1e-7;

// How far the LP may move a return of weight `weakest`: it may spend its residual budget
// epsilon * ||v||_1 on moving returns as well as dimming them, and moving one by dphi at the
// lowest frequency changes the data by ~weakest * dphi * sum_k h_k in L1 (harmonics h_k = 1, 2,
// 3). Measured on every bin of grids of 64..2048 bins, single returns move by at most 0.52 of
// this (1.4 bins of 512); it shrinks in proportion to epsilon.
double SraShiftBudgetS(const std::vector<Complex>& m, double weakest) {
  double data_l1 = 0.0;
  for (const Complex& value : m) data_l1 += std::abs(value.real()) + std::abs(value.imag());
  const double phase_budget = kEpsilon * data_l1 / (weakest * 6.0);
  return phase_budget / kTwoPi * kSraPeriodS;
}

TEST(Sra, FindsOneDiracOnAGridPointWithTheBoundedBrightnessLoss) {
  // The optimum keeps a total weight in [a (1 - rho eps), a (1 - eps)], rho <= (1 + sqrt 2)/2
  // (baselines.h); at tau = 0 all phases are multiples of pi/2, so rho = 1: exactly 1 - eps,
  // and the return stays on its bin. Bin 20 is one that the LP moves by more than a bin.
  for (int bin : {0, 20, 37, 300, 511}) {
    const Truth truth{{bin * kBinS}, {1.0}};
    const std::vector<Complex> m = Measure(truth, kSraHz);
    absl::StatusOr<SparseReturns> r = Sra(kSraHz, m, kEpsilon, kGridBins);
    ASSERT_THAT(r.status(), IsOk());
    ExpectWellFormed(*r, kSraPeriodS);
    ASSERT_EQ(r->weight.size(), 1u) << "bin " << bin;
    EXPECT_LE(CircularDistance(r->time_of_flight_s[0], truth.time_s[0], kSraPeriodS),
              bin == 0 ? kLpTolerance * kBinS : SraShiftBudgetS(m, 1.0))
        << "bin " << bin;
    const double rho = bin == 0 ? 1.0 : (1.0 + std::numbers::sqrt2) / 2.0;
    EXPECT_GE(r->weight[0], 1.0 - rho * kEpsilon - kLpTolerance) << "bin " << bin;
    EXPECT_LE(r->weight[0], 1.0 - kEpsilon + kLpTolerance) << "bin " << bin;
  }
}

TEST(Sra, MergesNeighbouringBinsOfAnOffGridDirac) {
  const Truth truth{{100.5 * kBinS}, {1.0}};
  const std::vector<Complex> m = Measure(truth, kSraHz);
  absl::StatusOr<SparseReturns> r = Sra(kSraHz, m, kEpsilon, kGridBins);
  ASSERT_THAT(r.status(), IsOk());
  ExpectRecovers(*r, truth, kSraPeriodS, SraShiftBudgetS(m, 1.0), 1.5 * kEpsilon);
}

TEST(Sra, FindsTwoSeparatedDiracs) {
  const Truth truth{{40 * kBinS, 260 * kBinS}, {1.0, 0.5}};
  const std::vector<Complex> m = Measure(truth, kSraHz);
  absl::StatusOr<SparseReturns> r = Sra(kSraHz, m, kEpsilon, kGridBins);
  ASSERT_THAT(r.status(), IsOk());
  // Found 1.5 and 3.1 bins off, within the budget of the weaker return (5.5 bins). x = (1 -
  // epsilon) * truth is feasible, so the total is at most (1 - epsilon) * 1.5; the dimming may
  // fall on either return.
  ExpectRecovers(*r, truth, kSraPeriodS, SraShiftBudgetS(m, 0.5), 2.0 * kEpsilon * 1.5);
  EXPECT_LE(r->weight[0] + r->weight[1], (1.0 - kEpsilon) * 1.5 + kLpTolerance);
}

TEST(Sra, ScalesWeightsWithTheInput) {
  const Truth truth{{40 * kBinS}, {1e-6}};
  absl::StatusOr<SparseReturns> r = Sra(kSraHz, Measure(truth, kSraHz), kEpsilon, kGridBins);
  ASSERT_THAT(r.status(), IsOk());
  ASSERT_EQ(r->weight.size(), 1u);
  EXPECT_NEAR(r->weight[0], 1e-6 * (1.0 - kEpsilon), 1e-6 * 0.21 * kEpsilon);
}

// GLPK's per-thread environment is freed when each thread exits; under LeakSanitizer this test
// fails at exit if it is not.
TEST(Sra, WorksFromSeveralThreads) {
  std::vector<int> returns_found(3, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < 3; ++t) {
    threads.emplace_back([t, &returns_found] {
      const Truth truth{{(10 + 50 * t) * kBinS}, {1.0}};
      const std::vector<Complex> m = Measure(truth, kSraHz);
      absl::StatusOr<SparseReturns> r = Sra(kSraHz, m, kEpsilon, kGridBins);
      if (r.ok() && r->weight.size() == 1 &&
          CircularDistance(r->time_of_flight_s[0], truth.time_s[0], kSraPeriodS) <=
              SraShiftBudgetS(m, 1.0)) {
        returns_found[t] = 1;
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  EXPECT_THAT(returns_found, ::testing::Each(1));
}

TEST(Sra, GivesNoReturnForZeroInput) {
  const std::vector<Complex> zero(3, Complex(0.0));
  absl::StatusOr<SparseReturns> r = Sra(kSraHz, zero);
  ASSERT_THAT(r.status(), IsOk());
  EXPECT_TRUE(r->weight.empty());
}

TEST(Sra, RejectsBadArgumentsNamingTheProblem) {
  const std::vector<Complex> m(3, Complex(1.0));
  const std::vector<double> two_frequencies = {23e6, 46e6};
  EXPECT_THAT(Sra(two_frequencies, m).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("same length")));
  EXPECT_THAT(Sra({}, {}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("no frequencies")));
  const std::vector<double> negative = {23e6, -46e6, 69e6};
  EXPECT_THAT(Sra(negative, m).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("frequencies_hz[1]")));
  for (double epsilon : {0.0, 1.0, -0.1, std::nan("")}) {
    EXPECT_THAT(Sra(kSraHz, m, epsilon).status(),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("0 < epsilon < 1")));
  }
  for (int bins : {7, kMaxSraGridBins + 1}) {
    EXPECT_THAT(Sra(kSraHz, m, kEpsilon, bins).status(),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("grid_bins")));
  }
  std::vector<Complex> infinite = m;
  infinite[1] = Complex(0.0, std::numeric_limits<double>::infinity());
  EXPECT_THAT(Sra(kSraHz, infinite).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("measurements[1]")));
}

// --- All methods on arbitrary data -----------------------------------------------------

TEST(Baselines, GiveWellFormedReturnsOnRandomInputs) {
  std::mt19937_64 rng(2121);
  std::normal_distribution<double> component(0.0, 1.0);
  const auto random_measurements = [&](int count) {
    std::vector<Complex> m;
    for (int k = 0; k < count; ++k) m.emplace_back(component(rng), component(rng));
    return m;
  };
  for (int trial = 0; trial < 40; ++trial) {
    ExpectWellFormed(SingleFrequencyPhase(random_measurements(1)[0], kBaseHz), kBasePeriodS);
    absl::StatusOr<SparseReturns> godbaz = GodbazTwoDirac(random_measurements(4), kBaseHz);
    ASSERT_THAT(godbaz.status(), IsOk());
    ExpectWellFormed(*godbaz, kBasePeriodS);
    absl::StatusOr<SparseReturns> spumic = Spumic(random_measurements(6), kBaseHz, 2, trial % 3);
    ASSERT_THAT(spumic.status(), IsOk());
    ExpectWellFormed(*spumic, kBasePeriodS);
    absl::StatusOr<SparseReturns> sra = Sra(kSraHz, random_measurements(3), kEpsilon, 64);
    ASSERT_THAT(sra.status(), IsOk());
    ExpectWellFormed(*sra, kSraPeriodS);
  }
}

}  // namespace
}  // namespace transient::eval
