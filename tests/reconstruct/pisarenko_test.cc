#include "transient/reconstruct/pisarenko.h"

#include <gtest/gtest.h>

#include <limits>
#include <random>
#include <vector>

#include "test_measures.h"

namespace transient {
namespace {

// Noise-free m-sparse measures whose returns are at least 3/4 of the resolution 2*pi/m
// apart. Closer returns make the moments insensitive to where exactly they are: at m = 14,
// returns 0.21 rad apart amplify rounding (1e-16) to ~1.5e-9 in the phases, whatever the
// method. The eigenvector alone is accurate to u * ||C|| / (eigenvalue gap); the Gauss-Newton
// polish on the moment equations takes the rest of the way.
constexpr double kExactTolerance = 1e-9;

// m returns on a jittered grid: phase_k = offset + 2*pi*(k + U(-1/8, 1/8)) / m.
testing::SparseMeasure ResolvedSparseMeasure(int m, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> offset(0.0, kTwoPi), jitter(-0.125, 0.125),
      weight(0.2, 1.0);
  testing::SparseMeasure measure;
  const double start = offset(rng);
  for (int k = 0; k < m; ++k) {
    measure.phase.push_back(WrapPhase(start + kTwoPi * (k + jitter(rng)) / m));
    measure.weight.push_back(weight(rng));
  }
  return measure;
}

void ExpectMatches(const testing::SparseMeasure& truth, const PisarenkoEstimate& estimate,
                   double tolerance) {
  ASSERT_EQ(estimate.count, static_cast<int>(truth.phase.size()));
  std::vector<int> order(truth.phase.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return truth.phase[a] < truth.phase[b]; });
  for (int l = 0; l < estimate.count; ++l) {
    EXPECT_NEAR(estimate.phase[l], truth.phase[order[l]], tolerance) << "return " << l;
    EXPECT_NEAR(estimate.weight[l], truth.weight[order[l]], tolerance) << "return " << l;
  }
  EXPECT_NEAR(estimate.uniform, truth.uniform, tolerance);
}

TEST(Pisarenko, RecoversAnMSparseMeasureExactly) {
  std::mt19937_64 rng(13);
  for (int m = 1; m <= kMaxOrder; ++m) {
    for (int trial = 0; trial < 40; ++trial) {
      SCOPED_TRACE(::testing::Message() << "m = " << m << ", trial " << trial);
      const auto truth = ResolvedSparseMeasure(m, rng);
      PisarenkoEstimate estimate;
      ASSERT_TRUE(Pisarenko(truth.Moments(m), &estimate));
      ExpectMatches(truth, estimate, kExactTolerance);
    }
  }
}

TEST(Pisarenko, SplitsOffAKnownUniformComponent) {
  std::mt19937_64 rng(14);
  for (int m = 1; m <= 8; ++m) {
    const auto truth = testing::RandomSparseMeasure(m, 0.3, 0.37, rng);
    PisarenkoEstimate estimate;
    ASSERT_TRUE(Pisarenko(truth.Moments(m), &estimate));
    ExpectMatches(truth, estimate, kExactTolerance);
  }
}

TEST(Pisarenko, FewerReturnsThanMomentsAreFound) {
  // Two returns measured with m = 4: lambda_min = 0 is a triple eigenvalue, the eigenvector's
  // polynomial has spurious roots, and only the true returns carry weight.
  testing::SparseMeasure truth;
  truth.phase = {0.8, 2.9};
  truth.weight = {1.0, 0.4};
  PisarenkoEstimate estimate;
  ASSERT_TRUE(Pisarenko(truth.Moments(4), &estimate));
  ExpectMatches(truth, estimate, 1e-6);
}

TEST(Pisarenko, SplitsOffUniformWithFewerReturnsThanMoments) {
  // lambda_min = 0.2 is a repeated eigenvalue here (two returns, m = 5).
  testing::SparseMeasure truth;
  truth.phase = {1.1, 4.0};
  truth.weight = {0.7, 0.9};
  truth.uniform = 0.2;
  PisarenkoEstimate estimate;
  ASSERT_TRUE(Pisarenko(truth.Moments(5), &estimate));
  ExpectMatches(truth, estimate, 1e-9);
}

TEST(Pisarenko, ReproducesMomentsOfAGeneralMeasure) {
  // Any valid c, not only sparse ones, is reproduced by uniform + returns (§8.4.1).
  std::mt19937_64 rng(15);
  for (int m = 2; m <= 10; ++m) {
    const std::vector<Complex> c = testing::DensityMoments(
        [](double phi) {
          return testing::ExponentiallyModifiedGaussian(phi, 1.0, 0.1, 3.0) + 0.05;
        },
        m, 4096);
    PisarenkoEstimate estimate;
    ASSERT_TRUE(Pisarenko(c, &estimate));
    EXPECT_GT(estimate.uniform, 0.0);
    EXPECT_EQ(estimate.count, m);
    std::vector<Complex> back(m + 1);
    DiracMoments(std::span<const double>(estimate.phase.data(), estimate.count),
                 std::span<const double>(estimate.weight.data(), estimate.count), back);
    back[0] += estimate.uniform;
    for (int j = 0; j <= m; ++j) EXPECT_NEAR(std::abs(back[j] - c[j]), 0.0, 1e-9) << j;
  }
}

TEST(Pisarenko, RejectsInvalidInput) {
  PisarenkoEstimate estimate;
  EXPECT_FALSE(Pisarenko(std::vector<Complex>{0.0, 0.1}, &estimate));
  EXPECT_FALSE(Pisarenko(std::vector<Complex>{1.0, Complex(std::nan(""), 0.0)}, &estimate));
}

// PisarenkoByLevinson, the optimized kernels' route (optimized_pisarenko.cc): the reference's
// exactness where it takes a pixel, and declining where it cannot vouch for its result.
bool FastPisarenko(const std::vector<Complex>& c, PisarenkoEstimate* estimate) {
  const PisarenkoSearchGrid grid(static_cast<int>(c.size()) - 1);
  return PisarenkoByLevinson(c, grid, estimate);
}

TEST(PisarenkoByLevinson, RecoversAnMSparseMeasureExactly) {
  // lambda_min = 0: C(c) is singular, Levinson fails at 0 and Newton starts from Gershgorin's
  // bound.
  std::mt19937_64 rng(13);
  for (int m = 1; m <= kMaxOrder; ++m) {
    for (int trial = 0; trial < 40; ++trial) {
      SCOPED_TRACE(::testing::Message() << "m = " << m << ", trial " << trial);
      const auto truth = ResolvedSparseMeasure(m, rng);
      PisarenkoEstimate estimate;
      ASSERT_TRUE(FastPisarenko(truth.Moments(m), &estimate));
      ExpectMatches(truth, estimate, kExactTolerance);
    }
  }
}

TEST(PisarenkoByLevinson, SplitsOffAKnownUniformComponent) {
  std::mt19937_64 rng(14);
  for (int m = 1; m <= 8; ++m) {
    SCOPED_TRACE(::testing::Message() << "m = " << m);
    const auto truth = testing::RandomSparseMeasure(m, 0.3, 0.37, rng);
    PisarenkoEstimate estimate;
    ASSERT_TRUE(FastPisarenko(truth.Moments(m), &estimate));
    ExpectMatches(truth, estimate, kExactTolerance);
  }
}

TEST(PisarenkoByLevinson, ReproducesMomentsOfAGeneralMeasureAndAgreesWithTheReference) {
  for (int m = 2; m <= 10; ++m) {
    SCOPED_TRACE(::testing::Message() << "m = " << m);
    const std::vector<Complex> c = testing::DensityMoments(
        [](double phi) {
          return testing::ExponentiallyModifiedGaussian(phi, 1.0, 0.1, 3.0) + 0.05;
        },
        m, 4096);
    PisarenkoEstimate estimate, reference;
    ASSERT_TRUE(FastPisarenko(c, &estimate));
    ASSERT_TRUE(Pisarenko(c, &reference));
    ASSERT_EQ(estimate.count, reference.count);
    EXPECT_NEAR(estimate.uniform, reference.uniform, 1e-10);
    for (int l = 0; l < estimate.count; ++l) {
      EXPECT_NEAR(estimate.phase[l], reference.phase[l], 1e-9) << l;
      EXPECT_NEAR(estimate.weight[l], reference.weight[l], 1e-9) << l;
    }
    std::vector<Complex> back(m + 1);
    DiracMoments(std::span<const double>(estimate.phase.data(), estimate.count),
                 std::span<const double>(estimate.weight.data(), estimate.count), back);
    back[0] += estimate.uniform;
    for (int j = 0; j <= m; ++j) EXPECT_NEAR(std::abs(back[j] - c[j]), 0.0, 1e-9) << j;
  }
}

TEST(PisarenkoByLevinson, DeclinesARepeatedLambdaMin) {
  // Two returns measured with m = 4 (lambda_min = 0 three times) and m = 5 with a uniform
  // part: the eigenvector is not unique, and the reference's companion roots take these.
  testing::SparseMeasure two;
  two.phase = {0.8, 2.9};
  two.weight = {1.0, 0.4};
  PisarenkoEstimate estimate;
  EXPECT_FALSE(FastPisarenko(two.Moments(4), &estimate));
  two.uniform = 0.2;
  EXPECT_FALSE(FastPisarenko(two.Moments(5), &estimate));
}

TEST(PisarenkoByLevinson, DeclinesTwoReturnsWithinOneGridStep) {
  // The grid has 16 (m + 1) = 80 phases at m = 4, 0.079 rad apart: returns 0.01 rad apart
  // change sign twice between two of them, and the reference takes the pixel.
  testing::SparseMeasure close;
  close.phase = {1.00, 1.01, 4.0};
  close.weight = {1.0, 0.8, 0.5};
  close.uniform = 0.1;
  PisarenkoEstimate estimate;
  EXPECT_FALSE(FastPisarenko(close.Moments(4), &estimate));
  ASSERT_TRUE(Pisarenko(close.Moments(4), &estimate));
}

TEST(PisarenkoByLevinson, DeclinesInvalidInput) {
  PisarenkoEstimate estimate;
  EXPECT_FALSE(FastPisarenko(std::vector<Complex>{0.0, 0.1}, &estimate));
  EXPECT_FALSE(FastPisarenko(std::vector<Complex>{-1.0, 0.1}, &estimate));
  EXPECT_FALSE(FastPisarenko(std::vector<Complex>{1.0, Complex(std::nan(""), 0.0)}, &estimate));
  EXPECT_FALSE(
      FastPisarenko(std::vector<Complex>{std::numeric_limits<double>::infinity(), 0.5}, &estimate));
}

}  // namespace
}  // namespace transient
