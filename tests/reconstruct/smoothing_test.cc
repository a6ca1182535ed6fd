#include "transient/reconstruct/smoothing.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "tests/support/status_matchers.h"
#include "transient/reconstruct/kernels.h"

namespace transient {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

// float32 sums of at most (2*31)^2 terms of order 1, divided by a float32 weight sum.
constexpr double kFloatRelative = 2e-5;

MomentImage RandomImage(ImageGeometry geometry, int order, std::mt19937_64& rng,
                        double invalid_fraction) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::uniform_real_distribution<double> coin(0.0, 1.0);
  MomentImage image(geometry, order);
  for (float& v : image.real) v = u(rng);
  for (float& v : image.imag) v = u(rng);
  image.valid.resize(static_cast<size_t>(geometry.pixel_count()));
  for (uint8_t& v : image.valid) v = coin(rng) < invalid_fraction ? 0 : 1;
  return image;
}

// Direct 2-D weighted average over the square window of radius ceil(3 sigma) (the separable
// filter's support), in double: the oracle.
double DirectSmooth(const MomentImage& image, const std::vector<float>& plane, int j, double sigma,
                    int x, int y) {
  const int r = static_cast<int>(std::ceil(3.0 * sigma));
  const int w = image.geometry.width, h = image.geometry.height;
  double num = 0.0, den = 0.0;
  for (int dy = -r; dy <= r; ++dy) {
    for (int dx = -r; dx <= r; ++dx) {
      const int xx = x + dx, yy = y + dy;
      if (xx < 0 || yy < 0 || xx >= w || yy >= h) continue;
      const int64_t q = int64_t{yy} * w + xx;
      if (!image.valid.empty() && image.valid[q] == 0) continue;
      const double g = std::exp(-(dx * dx + dy * dy) / (2.0 * sigma * sigma));
      num += g * plane[j * image.geometry.pixel_count() + q];
      den += g;
    }
  }
  return num / den;
}

TEST(GaussianSmooth, DefaultSigmaIsTheThesisValue) { EXPECT_EQ(kDefaultSmoothingSigmaPx, 0.6); }

TEST(GaussianSmooth, MatchesADirectTwoDimensionalConvolution) {
  std::mt19937_64 rng(31);
  for (double sigma : {0.3, kDefaultSmoothingSigmaPx, 1.7}) {
    const MomentImage before = RandomImage({23, 17}, 2, rng, 0.0);
    MomentImage after = before;
    ASSERT_THAT(GaussianSmooth(sigma, &after), IsOk());
    for (int j = 0; j <= 2; ++j) {
      for (int y = 0; y < 17; ++y) {
        for (int x = 0; x < 23; ++x) {
          const int64_t p = int64_t{y} * 23 + x + j * 23 * 17;
          ASSERT_NEAR(after.real[p], DirectSmooth(before, before.real, j, sigma, x, y),
                      kFloatRelative)
              << sigma;
          ASSERT_NEAR(after.imag[p], DirectSmooth(before, before.imag, j, sigma, x, y),
                      kFloatRelative)
              << sigma;
        }
      }
    }
    EXPECT_NE(after.real, before.real);
  }
}

// The planes of a harmonic set: the listed ones come out as when all are smoothed, the others
// as they were.
TEST(GaussianSmooth, OnlyTheListedPlanesAreSmoothed) {
  std::mt19937_64 rng(37);
  const MomentImage before = RandomImage({19, 13}, 4, rng, 0.1);
  MomentImage all = before, some = before;
  ASSERT_THAT(GaussianSmooth(kDefaultSmoothingSigmaPx, &all), IsOk());
  const int planes[] = {0, 3};
  ASSERT_THAT(GaussianSmooth(kDefaultSmoothingSigmaPx, &some, planes), IsOk());
  const int64_t n = before.geometry.pixel_count();
  for (int j = 0; j <= 4; ++j) {
    const MomentImage& want = (j == 0 || j == 3) ? all : before;
    for (int64_t p = 0; p < n; ++p) {
      ASSERT_EQ(some.real[j * n + p], want.real[j * n + p]) << j << " " << p;
      ASSERT_EQ(some.imag[j * n + p], want.imag[j * n + p]) << j << " " << p;
    }
  }
}

// The planes are smoothed in parallel on KernelThreads() threads, each with scratch buffers
// kept from call to call: the values are the same on one thread as on two, and after calls on
// images of other sizes and orders.
TEST(GaussianSmooth, OneOrTwoThreadsAndEarlierCallsOfOtherSizesGiveTheSameValues) {
  const KernelOptions saved = GetKernelOptions();
  std::mt19937_64 rng(41);
  const MomentImage before = RandomImage({41, 29}, 4, rng, 0.1);
  SetKernelOptions({.threads = 1});
  MomentImage one_thread = before;
  ASSERT_THAT(GaussianSmooth(kDefaultSmoothingSigmaPx, &one_thread), IsOk());
  SetKernelOptions({.threads = 2});
  for (MomentImage other : {RandomImage({63, 47}, 8, rng, 0.2), RandomImage({7, 5}, 1, rng, 0.0)}) {
    ASSERT_THAT(GaussianSmooth(1.7, &other), IsOk());
  }
  MomentImage two_threads = before;
  ASSERT_THAT(GaussianSmooth(kDefaultSmoothingSigmaPx, &two_threads), IsOk());
  SetKernelOptions(saved);
  EXPECT_NE(one_thread.real, before.real);
  EXPECT_EQ(two_threads.real, one_thread.real);
  EXPECT_EQ(two_threads.imag, one_thread.imag);
}

TEST(GaussianSmooth, InvalidPixelsNeitherContributeNorChange) {
  std::mt19937_64 rng(32);
  const MomentImage before = RandomImage({19, 13}, 3, rng, 0.25);
  MomentImage poisoned = before;
  const int64_t n = before.geometry.pixel_count();
  for (int64_t p = 0; p < n; ++p) {
    if (before.valid[p]) continue;
    for (int j = 0; j <= 3; ++j) poisoned.real_plane(j)[p] = (p % 2) ? std::nanf("") : 1e30f;
  }
  MomentImage after = poisoned;
  ASSERT_THAT(GaussianSmooth(1.0, &after), IsOk());
  for (int j = 0; j <= 3; ++j) {
    for (int64_t p = 0; p < n; ++p) {
      const int x = static_cast<int>(p % 19), y = static_cast<int>(p / 19);
      if (!before.valid[p]) {  // untouched, NaN included
        const float was = poisoned.real_plane(j)[p];
        EXPECT_TRUE(std::isnan(was) ? std::isnan(after.real_plane(j)[p])
                                    : after.real_plane(j)[p] == was);
        continue;
      }
      EXPECT_NEAR(after.real_plane(j)[p], DirectSmooth(before, before.real, j, 1.0, x, y),
                  kFloatRelative);
    }
  }
}

TEST(GaussianSmooth, AValidPixelWithNonFiniteMomentsDoesNotSpread) {
  std::mt19937_64 rng(33);
  MomentImage image = RandomImage({9, 9}, 1, rng, 0.0);
  image.imag_plane(1)[40] = std::numeric_limits<float>::infinity();
  MomentImage expected_mask = image;
  expected_mask.valid[40] = 0;
  ASSERT_THAT(GaussianSmooth(0.8, &image), IsOk());
  for (int64_t p = 0; p < 81; ++p) {
    if (p == 40) continue;
    ASSERT_TRUE(std::isfinite(image.real_plane(1)[p])) << p;
    EXPECT_NEAR(image.real_plane(1)[p],
                DirectSmooth(expected_mask, expected_mask.real, 1, 0.8, p % 9, p / 9),
                kFloatRelative);
  }
}

TEST(GaussianSmooth, ConstantImageIsUnchangedIncludingBordersAndHoles) {
  std::mt19937_64 rng(34);
  MomentImage image = RandomImage({31, 11}, 2, rng, 0.3);
  for (int j = 0; j <= 2; ++j) {
    std::fill_n(image.real_plane(j), 31 * 11, 3.5f + j);
    std::fill_n(image.imag_plane(j), 31 * 11, -1.25f * j);
  }
  const MomentImage before = image;
  ASSERT_THAT(GaussianSmooth(2.5, &image), IsOk());
  for (size_t i = 0; i < image.real.size(); ++i) {
    EXPECT_NEAR(image.real[i], before.real[i], kFloatRelative * 4);
    EXPECT_NEAR(image.imag[i], before.imag[i], kFloatRelative * 4);
  }
}

TEST(GaussianSmooth, ZeroSigmaChangesNothing) {
  std::mt19937_64 rng(35);
  MomentImage image = RandomImage({7, 6}, 3, rng, 0.2);
  const MomentImage before = image;
  ASSERT_THAT(GaussianSmooth(0.0, &image), IsOk());
  EXPECT_EQ(image.real, before.real);
  EXPECT_EQ(image.imag, before.imag);
}

TEST(GaussianSmooth, RefusesBadSigmaAndBadImages) {
  MomentImage image(ImageGeometry{4, 4}, 2);
  for (double sigma : {-0.1, 10.5, std::nan(""), std::numeric_limits<double>::infinity()}) {
    EXPECT_THAT(GaussianSmooth(sigma, &image),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         HasSubstr("Violated constraint: finite and 0 <= sigma_px <= 10")));
  }
  EXPECT_THAT(ValidateSmoothingSigma(-0.1),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("sigma_px = -0.1")));
  EXPECT_THAT(ValidateSmoothingSigma(10.0), IsOk());
  image.real.pop_back();
  EXPECT_THAT(GaussianSmooth(1.0, &image),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("moment planes hold")));
}

}  // namespace
}  // namespace transient
