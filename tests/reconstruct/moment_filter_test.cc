#include "transient/reconstruct/moment_filter.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "absl/strings/str_format.h"
#include "tests/support/status_matchers.h"
#include "transient/reconstruct/kernels.h"

namespace transient {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

// Fast path vs double reference: each pass sums 2r + 1 <= 15 float products of values in
// [-1, 1] with a float-rounded normalised kernel (weights off by 2^-24 relative), so an output
// is off by about 2 * 15 * 2^-24 ~ 2e-6 at worst; the reference's own float cast adds 6e-8.
constexpr double kFloatFilterTolerance = 4e-6;
// A constant c stays c up to the rounding of kernel weights that sum to 1 +- (2r + 1) * 2^-24.
constexpr double kConstantRelative = 2e-6;
// Box sums of <= 53 * 41 floats in [-1, 1] in double: entries <= 2173, 2^-53 relative each.
constexpr double kSatTolerance = 1e-12;

std::vector<float> RandomPlanes(ImageGeometry geometry, int channels, std::mt19937_64& rng,
                                float low = -1.0f, float high = 1.0f) {
  std::uniform_real_distribution<float> u(low, high);
  std::vector<float> planes(static_cast<size_t>(channels * geometry.pixel_count()));
  for (float& v : planes) v = u(rng);
  return planes;
}

// --- Gaussian ---------------------------------------------------------------------------------

TEST(GaussianMomentFilter, RadiusIsCeilOfThreeSigma) {
  const ImageGeometry geometry{64, 48};
  for (auto [sigma, radius] : {std::pair{0.5, 2}, {1.0, 3}, {1.1, 4}, {4.0, 12}}) {
    absl::StatusOr<GaussianMomentFilter> filter = GaussianMomentFilter::Create(sigma, geometry, 1);
    ASSERT_THAT(filter.status(), IsOk());
    EXPECT_EQ(filter->radius(), radius) << "sigma " << sigma;
  }
}

TEST(GaussianMomentFilter, ImpulseGivesTheNormalisedSeparableKernel) {
  const ImageGeometry geometry{21, 19};
  const double sigma = 1.5;
  const int r = 5;  // ceil(4.5)
  std::vector<float> in(static_cast<size_t>(geometry.pixel_count()), 0.0f);
  const int cx = 10, cy = 9;
  in[static_cast<size_t>(cy * geometry.width + cx)] = 1.0f;
  std::vector<float> out(in.size());
  absl::StatusOr<GaussianMomentFilter> filter = GaussianMomentFilter::Create(sigma, geometry, 1);
  ASSERT_THAT(filter.status(), IsOk());
  ASSERT_THAT(filter->Apply(in, out), IsOk());
  double norm = 0.0;
  for (int d = -r; d <= r; ++d) norm += std::exp(-d * d / (2 * sigma * sigma));
  double total = 0.0;
  for (int y = 0; y < geometry.height; ++y) {
    for (int x = 0; x < geometry.width; ++x) {
      const int dx = x - cx, dy = y - cy;
      const double expected =
          std::abs(dx) > r || std::abs(dy) > r
              ? 0.0
              : std::exp(-(dx * dx + dy * dy) / (2 * sigma * sigma)) / (norm * norm);
      const float got = out[static_cast<size_t>(y * geometry.width + x)];
      EXPECT_NEAR(got, expected, kFloatFilterTolerance) << "x " << x << " y " << y;
      total += got;
    }
  }
  EXPECT_NEAR(total, 1.0, kConstantRelative);
}

TEST(GaussianMomentFilter, FastPathMatchesTheDirectTwoDimensionalConvolution) {
  std::mt19937_64 rng(7);
  const ImageGeometry geometry{37, 29};
  const int channels = 3;
  for (double sigma : {0.5, 1.0, 2.3}) {
    const std::vector<float> in = RandomPlanes(geometry, channels, rng);
    std::vector<float> fast(in.size()), direct(in.size());
    absl::StatusOr<GaussianMomentFilter> filter =
        GaussianMomentFilter::Create(sigma, geometry, channels);
    ASSERT_THAT(filter.status(), IsOk());
    ASSERT_THAT(filter->Apply(in, fast), IsOk());
    ASSERT_THAT(filter->ApplyReference(in, direct), IsOk());
    double worst = 0.0;
    for (size_t i = 0; i < in.size(); ++i) {
      worst = std::max(worst, std::abs(static_cast<double>(fast[i]) - direct[i]));
    }
    EXPECT_LE(worst, kFloatFilterTolerance) << "sigma " << sigma;
    // The filter did something: a smoothed random image differs from its input.
    EXPECT_GT(std::abs(fast[0] - in[0]) + std::abs(fast[500] - in[500]), 1e-3);
  }
}

// Threads split the image into bands of rows, each re-filtering the rows around its ends; the
// result must not depend on the split (bit for bit: every pixel sums the same terms in the same
// order) and must match the reference across band boundaries.
TEST(GaussianMomentFilter, FastPathIsTheSameForAnyNumberOfThreads) {
  std::mt19937_64 rng(13);
  const ImageGeometry geometry{23, 150};
  const std::vector<float> in = RandomPlanes(geometry, 2, rng);
  absl::StatusOr<GaussianMomentFilter> filter = GaussianMomentFilter::Create(1.3, geometry, 2);
  ASSERT_THAT(filter.status(), IsOk());
  std::vector<float> direct(in.size());
  ASSERT_THAT(filter->ApplyReference(in, direct), IsOk());
  const KernelOptions saved = GetKernelOptions();
  std::vector<float> single(in.size());
  SetKernelOptions({.kind = KernelKind::kOptimized, .threads = 1});
  ASSERT_THAT(filter->Apply(in, single), IsOk());
  for (int threads : {2, 3}) {  // 4 and 6 bands per channel against 2
    SetKernelOptions({.kind = KernelKind::kOptimized, .threads = threads});
    std::vector<float> split(in.size());
    ASSERT_THAT(filter->Apply(in, split), IsOk());
    EXPECT_EQ(split, single) << threads << " threads";
    for (size_t i = 0; i < in.size(); ++i) {
      ASSERT_NEAR(split[i], direct[i], kFloatFilterTolerance) << threads << " threads, at " << i;
    }
  }
  SetKernelOptions(saved);
}

TEST(GaussianMomentFilter, ConstantImageStaysConstantUpToTheBorders) {
  const ImageGeometry geometry{64, 48};
  const std::vector<float> in(static_cast<size_t>(2 * geometry.pixel_count()), 0.37f);
  for (double sigma : {1.0, 4.0}) {  // r = 12: most pixels see the clamped border
    absl::StatusOr<GaussianMomentFilter> filter = GaussianMomentFilter::Create(sigma, geometry, 2);
    ASSERT_THAT(filter.status(), IsOk());
    std::vector<float> fast(in.size()), direct(in.size());
    ASSERT_THAT(filter->Apply(in, fast), IsOk());
    ASSERT_THAT(filter->ApplyReference(in, direct), IsOk());
    for (size_t i = 0; i < in.size(); ++i) {
      ASSERT_NEAR(fast[i], 0.37, 0.37 * kConstantRelative) << "sigma " << sigma << " at " << i;
      ASSERT_NEAR(direct[i], 0.37, 0.37 * kConstantRelative) << "sigma " << sigma << " at " << i;
    }
  }
}

TEST(GaussianMomentFilter, FilterAsWideAsTheImageIsAccepted) {
  const ImageGeometry geometry{7, 9};  // sigma = 1: 2 * 3 + 1 = 7 = width
  absl::StatusOr<GaussianMomentFilter> filter = GaussianMomentFilter::Create(1.0, geometry, 1);
  ASSERT_THAT(filter.status(), IsOk());
  std::mt19937_64 rng(3);
  const std::vector<float> in = RandomPlanes(geometry, 1, rng);
  std::vector<float> fast(in.size()), direct(in.size());
  ASSERT_THAT(filter->Apply(in, fast), IsOk());
  ASSERT_THAT(filter->ApplyReference(in, direct), IsOk());
  for (size_t i = 0; i < in.size(); ++i) EXPECT_NEAR(fast[i], direct[i], kFloatFilterTolerance);
}

TEST(GaussianMomentFilter, BadSigmaIsRejected) {
  const ImageGeometry geometry{64, 48};
  for (double sigma : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN(),
                       std::numeric_limits<double>::infinity()}) {
    EXPECT_THAT(GaussianMomentFilter::Create(sigma, geometry, 4).status(),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         AllOf(HasSubstr("sigma_px = "), HasSubstr("sigma_px > 0"))))
        << sigma;
  }
}

TEST(GaussianMomentFilter, FilterWiderThanTheImageIsRejectedNamingSigmaAndSize) {
  // sigma = 2: 2 * 6 + 1 = 13 > 10 rows.
  EXPECT_THAT(GaussianMomentFilter::Create(2.0, {40, 10}, 4).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("sigma_px = 2"), HasSubstr("13 px"),
                             HasSubstr("wider than the image of 40 x 10"))));
  // A huge sigma must not overflow the radius on its way to the same error.
  EXPECT_THAT(GaussianMomentFilter::Create(1e300, {640, 480}, 4).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("wider than the image")));
}

TEST(GaussianMomentFilter, EmptyImageOrNoChannelsIsRejected) {
  EXPECT_THAT(GaussianMomentFilter::Create(1.0, {0, 10}, 4).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("width, height > 0")));
  EXPECT_THAT(GaussianMomentFilter::Create(1.0, {10, 10}, 0).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("channels >= 1")));
}

TEST(GaussianMomentFilter, MismatchedBufferSizesAreRejected) {
  const ImageGeometry geometry{16, 12};
  absl::StatusOr<GaussianMomentFilter> filter = GaussianMomentFilter::Create(1.0, geometry, 4);
  ASSERT_THAT(filter.status(), IsOk());
  std::vector<float> good(static_cast<size_t>(4 * geometry.pixel_count()), 0.5f);
  std::vector<float> short_buffer(good.size() - 1, 0.5f);
  std::vector<float> out(good.size());
  EXPECT_THAT(filter->Apply(short_buffer, out),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("input size = 767"), HasSubstr("4 * 16 * 12 = 768"))));
  std::vector<float> long_out(good.size() + 1);
  EXPECT_THAT(filter->Apply(good, long_out),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("output size = 769")));
  EXPECT_THAT(filter->ApplyReference(short_buffer, out),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("input size = 767")));
}

TEST(GaussianMomentFilter, NonFiniteInputIsRejectedAndTheOutputLeftUntouched) {
  const ImageGeometry geometry{16, 12};
  absl::StatusOr<GaussianMomentFilter> filter = GaussianMomentFilter::Create(1.0, geometry, 2);
  ASSERT_THAT(filter.status(), IsOk());
  for (float bad :
       {std::numeric_limits<float>::quiet_NaN(), -std::numeric_limits<float>::infinity()}) {
    std::vector<float> in(static_cast<size_t>(2 * geometry.pixel_count()), 0.5f);
    in[static_cast<size_t>(geometry.pixel_count() + 2 * 16 + 3)] = bad;  // channel 1, (3, 2)
    std::vector<float> out(in.size(), -7.0f);
    EXPECT_THAT(filter->Apply(in, out), StatusIs(absl::StatusCode::kInvalidArgument,
                                                 AllOf(HasSubstr("channel 1, pixel (x 3, y 2)"),
                                                       HasSubstr("every value finite"))));
    EXPECT_TRUE(std::all_of(out.begin(), out.end(), [](float v) { return v == -7.0f; }));
  }
}

// --- Summed-area table ------------------------------------------------------------------------

double DirectBoxSum(const std::vector<float>& planes, ImageGeometry g, int channel, int x0, int y0,
                    int x1, int y1) {
  double sum = 0.0;
  for (int y = std::max(y0, 0); y <= std::min(y1, g.height - 1); ++y) {
    for (int x = std::max(x0, 0); x <= std::min(x1, g.width - 1); ++x) {
      sum += planes[static_cast<size_t>(channel * g.pixel_count() + int64_t{y} * g.width + x)];
    }
  }
  return sum;
}

TEST(SummedAreaTable, BoxMeanEqualsADirectSumForRandomRectanglesIncludingEdges) {
  std::mt19937_64 rng(11);
  const ImageGeometry g{53, 41};
  const int channels = 2;
  const std::vector<float> planes = RandomPlanes(g, channels, rng);
  absl::StatusOr<SummedAreaTable> sat = SummedAreaTable::Build(g, channels, planes);
  ASSERT_THAT(sat.status(), IsOk());
  // Random corners reaching 4 px past every edge, plus the whole image and its corner pixels.
  std::uniform_int_distribution<int> ux(-4, g.width + 3), uy(-4, g.height + 3);
  std::vector<std::array<int, 4>> boxes = {{0, 0, g.width - 1, g.height - 1},
                                           {0, 0, 0, 0},
                                           {g.width - 1, 0, g.width - 1, 0},
                                           {0, g.height - 1, 0, g.height - 1},
                                           {g.width - 1, g.height - 1, g.width - 1, g.height - 1}};
  for (int i = 0; i < 300; ++i) {
    int x0 = ux(rng), x1 = ux(rng), y0 = uy(rng), y1 = uy(rng);
    if (i % 3 != 0) {  // mostly proper rectangles; every third may be empty (x1 < x0 or y1 < y0)
      if (x1 < x0) std::swap(x0, x1);
      if (y1 < y0) std::swap(y0, y1);
    }
    boxes.push_back({x0, y0, x1, y1});
  }
  int nonempty = 0;
  for (const auto& [x0, y0, x1, y1] : boxes) {
    const int64_t area = int64_t{std::max(0, std::min(x1, g.width - 1) - std::max(x0, 0) + 1)} *
                         std::max(0, std::min(y1, g.height - 1) - std::max(y0, 0) + 1);
    ASSERT_EQ(sat->BoxArea(x0, y0, x1, y1), area) << x0 << " " << y0 << " " << x1 << " " << y1;
    nonempty += area > 0;
    std::array<double, channels> means;
    ASSERT_EQ(sat->BoxMeans(x0, y0, x1, y1, means), area);
    for (int k = 0; k < channels; ++k) {
      const double sum = DirectBoxSum(planes, g, k, x0, y0, x1, y1);
      const double mean = area > 0 ? sum / static_cast<double>(area) : 0.0;
      EXPECT_NEAR(sat->BoxSum(k, x0, y0, x1, y1), sum, kSatTolerance);
      EXPECT_NEAR(sat->BoxMean(k, x0, y0, x1, y1), mean, kSatTolerance);
      EXPECT_NEAR(means[static_cast<size_t>(k)], mean, kSatTolerance);
    }
  }
  EXPECT_GT(nonempty, 200);  // the random rectangles mostly overlap the image
}

TEST(SummedAreaTable, EmptyOrOutsideRectanglesHaveAreaZeroAndMeanZero) {
  const ImageGeometry g{8, 6};
  const std::vector<float> planes(static_cast<size_t>(g.pixel_count()), 2.0f);
  absl::StatusOr<SummedAreaTable> sat = SummedAreaTable::Build(g, 1, planes);
  ASSERT_THAT(sat.status(), IsOk());
  for (const auto& [x0, y0, x1, y1] : std::vector<std::array<int, 4>>{
           {3, 2, 2, 4},     // x1 < x0
           {3, 2, 4, 1},     // y1 < y0
           {8, 0, 12, 5},    // right of the image
           {-5, -5, -1, 3},  // left of it
           {0, 6, 7, 9},     // below it
           {std::numeric_limits<int>::min(), std::numeric_limits<int>::min(), -1, -1}}) {
    EXPECT_EQ(sat->BoxArea(x0, y0, x1, y1), 0);
    EXPECT_EQ(sat->BoxSum(0, x0, y0, x1, y1), 0.0);
    EXPECT_EQ(sat->BoxMean(0, x0, y0, x1, y1), 0.0);
  }
  // The largest possible rectangle clamps to the image.
  const int big = std::numeric_limits<int>::max(), small = std::numeric_limits<int>::min();
  EXPECT_EQ(sat->BoxArea(small, small, big, big), g.pixel_count());
  EXPECT_EQ(sat->BoxMean(0, small, small, big, big), 2.0);
}

// A table the size of a large moment map, of values in [0, 1]. The one-pixel box at the far
// corner is the hardest query: the difference of four entries of ~pixel_count / 2. Double
// entries keep it within 1e-6 relative even by the worst-case bound (4 * (w + h) * 2^-53 *
// pixel_count / 2 / value ~ 1e-6 here for value >= 0.5; measured: 0, here and at 4096^2); a
// naive float table (entries ~2^19, one ulp = 1/16) is off by percent (3% here, 48% at 4096^2).
// 1024^2 keeps the test fast; the float table only gets worse with size.
TEST(SummedAreaTable, LargeTableKeepsPrecisionWhereANaiveFloatTableDoesNot) {
  constexpr int kSize = 1024;
  const ImageGeometry g{kSize, kSize};
  std::mt19937_64 rng(5);
  std::vector<float> planes = RandomPlanes(g, 1, rng, 0.0f, 1.0f);
  // A relative error needs a value away from 0; not a multiple of float's grid at 2^19 either.
  if (planes.back() < 0.5f) planes.back() += 0.5f;
  absl::StatusOr<SummedAreaTable> sat = SummedAreaTable::Build(g, 1, planes);
  ASSERT_THAT(sat.status(), IsOk());

  // The naive float table, row prefix sums then column prefix sums, as a GPU would store it.
  std::vector<float> naive(planes);
  for (int y = 0; y < kSize; ++y) {
    for (int x = 1; x < kSize; ++x) naive[y * kSize + x] += naive[y * kSize + x - 1];
  }
  for (int y = 1; y < kSize; ++y) {
    for (int x = 0; x < kSize; ++x) naive[y * kSize + x] += naive[(y - 1) * kSize + x];
  }
  const int last = kSize - 1;
  const double truth = planes.back();
  const double naive_value = static_cast<double>(naive[last * kSize + last]) -
                             naive[(last - 1) * kSize + last] - naive[last * kSize + last - 1] +
                             naive[(last - 1) * kSize + last - 1];
  const double double_error = std::abs(sat->BoxMean(0, last, last, last, last) - truth) / truth;
  const double naive_error = std::abs(naive_value - truth) / truth;
  RecordProperty("double_relative_error", absl::StrFormat("%.3g", double_error));
  RecordProperty("naive_float_relative_error", absl::StrFormat("%.3g", naive_error));
  EXPECT_LE(double_error, 1e-6);
  EXPECT_GT(naive_error, 1e-3);  // the reason the table is double
  // A wide box over the whole last row too.
  const double row_truth = DirectBoxSum(planes, g, 0, 0, last, last, last) / kSize;
  EXPECT_NEAR(sat->BoxMean(0, 0, last, last, last), row_truth, 1e-6 * row_truth);
}

TEST(SummedAreaTable, BadInputIsRejected) {
  const ImageGeometry g{8, 6};
  std::vector<float> planes(static_cast<size_t>(3 * g.pixel_count()), 0.25f);
  EXPECT_THAT(SummedAreaTable::Build(g, 2, planes).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("input size = 144"), HasSubstr("2 * 8 * 6 = 96"))));
  EXPECT_THAT(SummedAreaTable::Build({8, 0}, 3, planes).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("width, height > 0")));
  EXPECT_THAT(SummedAreaTable::Build(g, 0, planes).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("channels >= 1")));
  planes[static_cast<size_t>(2 * g.pixel_count() + 5 * 8 + 7)] =
      std::numeric_limits<float>::quiet_NaN();
  EXPECT_THAT(
      SummedAreaTable::Build(g, 3, planes).status(),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("channel 2, pixel (x 7, y 5)")));
}

}  // namespace
}  // namespace transient
