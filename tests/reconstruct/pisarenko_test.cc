#include "transient/reconstruct/pisarenko.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "test_measures.h"

namespace transient {
namespace {

// Noise-free m-sparse measures with returns >= 0.25 rad apart: the Vandermonde system is well
// conditioned and the eigenvector is accurate to a few ulps of ||C||.
constexpr double kExactTolerance = 1e-9;

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
    for (int trial = 0; trial < 5; ++trial) {
      const auto truth = testing::RandomSparseMeasure(m, 0.25 * 8.0 / std::max(m, 8), 0.0, rng);
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

}  // namespace
}  // namespace transient
