#include "transient/reconstruct/moment_depth_map.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "tests/support/status_matchers.h"
#include "transient/reconstruct/kernels.h"

namespace transient {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

constexpr float kInfF = std::numeric_limits<float>::infinity();
constexpr DepthNormalisation kRange{.near_m = 0.5, .far_m = 4.5};  // z̄ = (d - 2.5) / 2
constexpr MomentMapFormat kFormats[] = {MomentMapFormat::kOptimized64, MomentMapFormat::kFloat128};

// Fast path (float moments, separable float filter, float division) against the reference
// (double moments rounded once to float, direct convolution in double): each filter pass sums
// 2r + 1 <= 13 float products (sigma <= 2), so a filtered channel is off by ~2 * 13 * 2^-24 of
// the filtered coverage (moment_filter_test's argument; |z̄| <= 1 bounds each term by the
// coverage weight), and b / b_0 inherits that relative error: 4e-6 in absolute terms.
constexpr double kMomentTolerance = 4e-6;
// Θ of eq. 4.4 weighs moment errors by at most 1.5 + 2 = 3.5: 1.4e-5 < one code (1.5e-5), so the
// rounded codes differ by at most one.
constexpr int kCodeTolerance = 1;
// Occlusion from the fast texel against the reference texel, queried halfway between the
// scene's depth levels (0.25 normalised units from every surface): the moments differ by
// kMomentTolerance (float) or one code (~1e-5 in b, 64-bit), a fraction of the bias α
// (1e-5, 6e-5) that keeps the Hankel matrix away from singular. Measured on these scenes: 4e-5
// (float; moments 1.8e-7 apart) and 3.2e-3 (64-bit, codes one LSB apart); allowed: 10 α and
// 100 α.
constexpr double kFloatOcclusionTolerance = 10 * kFloatMomentBias.alpha;
constexpr double kQuantizedOcclusionTolerance = 100 * kQuantized16MomentBias.alpha;

absl::StatusOr<MomentDepthMapBuilder> MakeBuilder(ImageGeometry geometry, double sigma_px,
                                                  MomentMapFormat format) {
  return MomentDepthMapBuilder::Create(
      geometry, {.normalisation = kRange, .sigma_px = sigma_px, .format = format});
}

std::string Name(MomentMapFormat format) {
  return format == MomentMapFormat::kOptimized64 ? "kOptimized64" : "kFloat128";
}

// Rectangles at the depth levels 1, 2, 3, 4 m (z̄ = -0.75, -0.25, 0.25, 0.75) over a background
// at 3 m: sharp edges between levels. A tenth of the pixels NaN, in scattered pixels and one
// block, and a few depths outside [near, far] (0.2 m and 6 m, clamped to the levels ±1).
std::vector<float> RandomScene(ImageGeometry geometry, std::mt19937_64& rng) {
  std::uniform_int_distribution<int> x_of(0, geometry.width - 1), y_of(0, geometry.height - 1),
      level(1, 4);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> depth(static_cast<size_t>(geometry.pixel_count()), 3.0f);
  auto at = [&](int x, int y) -> float& {
    return depth[static_cast<size_t>(int64_t{y} * geometry.width + x)];
  };
  for (int rect = 0; rect < 6; ++rect) {
    const int x0 = x_of(rng), y0 = y_of(rng);
    const int x1 = std::min(geometry.width - 1, x0 + x_of(rng) / 2);
    const int y1 = std::min(geometry.height - 1, y0 + y_of(rng) / 2);
    const float d = static_cast<float>(level(rng));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) at(x, y) = d;
    }
  }
  const int bx = x_of(rng) / 2, by = y_of(rng) / 2;  // a NaN block of 5 x 4
  for (int y = by; y < by + 4; ++y) {
    for (int x = bx; x < bx + 5; ++x) at(x, y) = kNaNf;
  }
  for (float& d : depth) {
    const float roll = u(rng);
    if (roll < 0.08f) {
      d = kNaNf;
    } else if (roll < 0.09f) {
      d = 0.2f;
    } else if (roll < 0.10f) {
      d = 6.0f;
    }
  }
  return depth;
}

// Queries halfway between levels and beyond them: 0.25 normalised units from every surface.
constexpr double kQueriesM[] = {0.5, 1.5, 2.5, 3.5, 4.5};

void ExpectEqualCounts(const MomentDepthMap& a, const MomentDepthMap& b) {
  EXPECT_EQ(a.invalid_depths, b.invalid_depths);
  EXPECT_EQ(a.clamped_depths, b.clamped_depths);
  EXPECT_EQ(a.empty_texels, b.empty_texels);
}

// The fast map agrees with the reference map texel by texel, in codes or moments and in the
// occlusion a renderer computes.
void ExpectMapsAgree(const MomentDepthMap& fast, const MomentDepthMap& reference,
                     const std::string& context) {
  ASSERT_EQ(fast.geometry, reference.geometry);
  ExpectEqualCounts(fast, reference);
  const bool quantized = fast.options.format == MomentMapFormat::kOptimized64;
  ASSERT_EQ(fast.quantized.size(), reference.quantized.size());
  ASSERT_EQ(fast.moments.size(), reference.moments.size());
  int worst_code = 0;
  double worst_moment = 0.0, worst_occlusion = 0.0;
  for (size_t i = 0; i < fast.quantized.size(); ++i) {
    worst_code = std::max(worst_code, std::abs(int{fast.quantized[i]} - reference.quantized[i]));
  }
  for (size_t i = 0; i < fast.moments.size(); ++i) {
    worst_moment = std::max(worst_moment, std::abs(double{fast.moments[i]} - reference.moments[i]));
  }
  for (int y = 0; y < fast.geometry.height; ++y) {
    for (int x = 0; x < fast.geometry.width; ++x) {
      for (const double depth : kQueriesM) {
        worst_occlusion = std::max(worst_occlusion, std::abs(double{fast.Occlusion(x, y, depth)} -
                                                             reference.Occlusion(x, y, depth)));
      }
    }
  }
  EXPECT_LE(worst_code, kCodeTolerance) << context;
  EXPECT_LE(worst_moment, kMomentTolerance) << context;
  EXPECT_LE(worst_occlusion, quantized ? kQuantizedOcclusionTolerance : kFloatOcclusionTolerance)
      << context;
}

// ---- options and inputs ------------------------------------------------------------------------

TEST(MomentDepthMapBuilder, InvalidOptionsAreRejectedNamingTheField) {
  const ImageGeometry geometry{16, 12};
  EXPECT_THAT(MomentDepthMapBuilder::Create(geometry, {.normalisation = {2.0, 2.0}}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("normalisation"), HasSubstr("near_m < far_m"))));
  EXPECT_THAT(MomentDepthMapBuilder::Create(geometry, {.normalisation = {3.0, 1.0}}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("near_m < far_m")));
  for (const double sigma : {-0.5, double{kNaNf}, double{kInfF}}) {
    EXPECT_THAT(
        MomentDepthMapBuilder::Create(geometry, {.normalisation = kRange, .sigma_px = sigma})
            .status(),
        StatusIs(absl::StatusCode::kInvalidArgument,
                 AllOf(HasSubstr("sigma_px"), HasSubstr("finite and >= 0"))))
        << sigma;
  }
  EXPECT_THAT(MomentDepthMapBuilder::Create({0, 12}, {.normalisation = kRange}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("width, height > 0")));
}

TEST(MomentDepthMapBuilder, FilterWiderThanTheImageIsRejected) {
  // sigma 2 needs 2 * 6 + 1 = 13 px; the image is 16 x 12.
  EXPECT_THAT(MakeBuilder({16, 12}, 2.0, MomentMapFormat::kFloat128).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("sigma_px = 2"), HasSubstr("16 x 12"))));
  EXPECT_THAT(MakeBuilder({16, 13}, 2.0, MomentMapFormat::kFloat128).status(), IsOk());
}

TEST(MomentDepthMapBuilder, WrongBufferSizesAreRejected) {
  const ImageGeometry geometry{8, 6};
  absl::StatusOr<MomentDepthMapBuilder> builder = MakeBuilder(geometry, 0.5, kFormats[0]);
  ASSERT_THAT(builder.status(), IsOk());
  MomentDepthMap map;
  const std::vector<float> short_depth(47, 1.0f), depth(48, 1.0f), two(96, 1.0f);
  EXPECT_THAT(builder->Build(short_depth, &map),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("depth_m size = 47"), HasSubstr("1 * 8 * 6 = 48"))));
  EXPECT_THAT(builder->BuildReference(short_depth, &map),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("depth_m size = 47")));
  EXPECT_THAT(builder->BuildFromReturns(0, {}, {}, &map),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("returns >= 1")));
  EXPECT_THAT(builder->BuildFromReturnsReference(-1, {}, {}, &map),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("returns = -1")));
  EXPECT_THAT(builder->BuildFromReturns(2, depth, two, &map),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("depth_m size = 48"), HasSubstr("2 * 8 * 6 = 96"))));
  EXPECT_THAT(builder->BuildFromReturns(2, two, depth, &map),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("weight size = 48")));
  EXPECT_THAT(builder->BuildFromReturnsReference(2, two, depth, &map),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("weight size = 48")));
  EXPECT_THAT(builder->Build(depth, &map), IsOk());
}

// ---- fast path against the reference -----------------------------------------------------------

TEST(MomentDepthMapBuilder, BuildMatchesTheReferenceOnScenesWithEdgesAndNaN) {
  const ImageGeometry geometry{37, 29};  // odd sizes: no SIMD-friendly multiple
  std::mt19937_64 rng(7);
  for (const MomentMapFormat format : kFormats) {
    for (const double sigma : {0.0, 0.6, 1.0, 2.0}) {
      absl::StatusOr<MomentDepthMapBuilder> builder = MakeBuilder(geometry, sigma, format);
      ASSERT_THAT(builder.status(), IsOk());
      for (int scene = 0; scene < 2; ++scene) {
        const std::vector<float> depth = RandomScene(geometry, rng);
        MomentDepthMap fast, reference;
        ASSERT_THAT(builder->Build(depth, &fast), IsOk());
        ASSERT_THAT(builder->BuildReference(depth, &reference), IsOk());
        EXPECT_GT(fast.invalid_depths, 0);
        EXPECT_GT(fast.clamped_depths, 0);
        ExpectMapsAgree(fast, reference, Name(format) + " sigma " + std::to_string(sigma));
      }
    }
  }
}

TEST(MomentDepthMapBuilder, BuildFromReturnsMatchesTheReference) {
  const ImageGeometry geometry{23, 19};
  const int64_t pixels = geometry.pixel_count();
  constexpr int kReturns = 3;
  std::mt19937_64 rng(8);
  std::uniform_int_distribution<int> level(1, 4);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> depth(static_cast<size_t>(kReturns * pixels)), weight(depth.size());
  for (size_t i = 0; i < depth.size(); ++i) {
    depth[i] = static_cast<float>(level(rng));
    weight[i] = u(rng);
    const float roll = u(rng);  // unusable entries: NaN depth, zero or NaN weight
    if (roll < 0.1f) {
      depth[i] = kNaNf;
    } else if (roll < 0.2f) {
      weight[i] = 0.0f;
    } else if (roll < 0.25f) {
      weight[i] = kNaNf;
    } else if (roll < 0.3f) {
      depth[i] = 7.0f;  // clamped
    }
  }
  for (const MomentMapFormat format : kFormats) {
    for (const double sigma : {0.0, 1.0}) {
      absl::StatusOr<MomentDepthMapBuilder> builder = MakeBuilder(geometry, sigma, format);
      ASSERT_THAT(builder.status(), IsOk());
      MomentDepthMap fast, reference;
      ASSERT_THAT(builder->BuildFromReturns(kReturns, depth, weight, &fast), IsOk());
      ASSERT_THAT(builder->BuildFromReturnsReference(kReturns, depth, weight, &reference), IsOk());
      EXPECT_GT(fast.invalid_depths, 0);
      EXPECT_GT(fast.clamped_depths, 0);
      ExpectMapsAgree(fast, reference, Name(format) + " sigma " + std::to_string(sigma));
    }
  }
}

TEST(MomentDepthMapBuilder, OneReturnPerPixelGivesTheDepthImageMap) {
  const ImageGeometry geometry{20, 16};
  std::mt19937_64 rng(9);
  const std::vector<float> depth = RandomScene(geometry, rng);
  const std::vector<float> weight(depth.size(), 0.5f);
  for (const MomentMapFormat format : kFormats) {
    absl::StatusOr<MomentDepthMapBuilder> builder = MakeBuilder(geometry, 1.0, format);
    ASSERT_THAT(builder.status(), IsOk());
    MomentDepthMap from_depth, from_returns;
    ASSERT_THAT(builder->Build(depth, &from_depth), IsOk());
    ASSERT_THAT(builder->BuildFromReturns(1, depth, weight, &from_returns), IsOk());
    ExpectMapsAgree(from_returns, from_depth, Name(format));
  }
}

TEST(MomentDepthMapBuilder, ThreadCountDoesNotChangeTheResult) {
  const ImageGeometry geometry{128, 96};  // three blocks of 4096 pixels per per-pixel pass
  std::mt19937_64 rng(10);
  const std::vector<float> depth = RandomScene(geometry, rng);
  const KernelOptions saved = GetKernelOptions();
  for (const MomentMapFormat format : kFormats) {
    absl::StatusOr<MomentDepthMapBuilder> builder = MakeBuilder(geometry, 1.5, format);
    ASSERT_THAT(builder.status(), IsOk());
    MomentDepthMap one, two;
    SetKernelOptions({.kind = KernelKind::kOptimized, .threads = 1});
    ASSERT_THAT(builder->Build(depth, &one), IsOk());
    SetKernelOptions({.kind = KernelKind::kOptimized, .threads = 2});
    ASSERT_THAT(builder->Build(depth, &two), IsOk());
    EXPECT_EQ(one.quantized, two.quantized) << Name(format);
    EXPECT_EQ(one.moments, two.moments) << Name(format);
    ExpectEqualCounts(one, two);
  }
  SetKernelOptions(saved);
}

// ---- invalid and out-of-range depth ------------------------------------------------------------

TEST(MomentDepthMapBuilder, NaNDepthCarriesNoWeight) {
  // Every valid pixel at 2 m, a third of them NaN: wherever a texel has valid depth in its
  // footprint, it is the single surface at 2 m (z̄ = -0.25) however the NaNs fall.
  const ImageGeometry geometry{24, 18};
  std::mt19937_64 rng(11);
  std::vector<float> depth(static_cast<size_t>(geometry.pixel_count()), 2.0f);
  for (float& d : depth) {
    if (rng() % 3 == 0) d = kNaNf;
  }
  const float z = -0.25f;
  const PowerMomentsF want = {1.0f, z, z * z, z * z * z, z * z * z * z};
  for (const MomentMapFormat format : kFormats) {
    absl::StatusOr<MomentDepthMapBuilder> builder = MakeBuilder(geometry, 1.0, format);
    ASSERT_THAT(builder.status(), IsOk());
    MomentDepthMap map;
    ASSERT_THAT(builder->Build(depth, &map), IsOk());
    EXPECT_EQ(map.empty_texels, 0);
    // 64-bit: one code is 1.5e-5 of Θ, which the inverse of eq. 4.4 scales by at most 3.5.
    const double tolerance = format == MomentMapFormat::kOptimized64 ? 6e-5 : kMomentTolerance;
    for (int y = 0; y < geometry.height; ++y) {
      for (int x = 0; x < geometry.width; ++x) {
        const PowerMomentsF b = map.Texel(x, y);
        for (int j = 0; j < kPowerMomentCount; ++j) {
          ASSERT_NEAR(b[j], want[j], tolerance) << Name(format) << " " << x << " " << y;
        }
      }
    }
  }
}

TEST(MomentDepthMapBuilder, TexelNextToNaNIsTheWeightedMeanOfItsValidNeighbours) {
  // sigma 1 (radius 3) around the centre (8, 6) of a 17 x 13 image: left half at 1 m, right
  // half at 4 m, the column x = 9 and the pixel (7, 5) NaN. Known answer: the Gaussian-weighted
  // mean of the valid pixels' moments, computed here in double.
  const ImageGeometry geometry{17, 13};
  const int cx = 8, cy = 6, r = 3;
  std::vector<float> depth(static_cast<size_t>(geometry.pixel_count()));
  for (int y = 0; y < geometry.height; ++y) {
    for (int x = 0; x < geometry.width; ++x) {
      float d = x < cx ? 1.0f : 4.0f;
      if (x == cx + 1 || (x == cx - 1 && y == cy - 1)) d = kNaNf;
      depth[static_cast<size_t>(y * geometry.width + x)] = d;
    }
  }
  PowerMoments sum{};
  for (int dy = -r; dy <= r; ++dy) {
    for (int dx = -r; dx <= r; ++dx) {
      const double d = depth[static_cast<size_t>((cy + dy) * geometry.width + cx + dx)];
      if (std::isnan(d)) continue;
      const double g = std::exp(-(dx * dx + dy * dy) / 2.0);
      const double z = kRange.Normalise(d);
      for (int j = 0; j < kPowerMomentCount; ++j) sum[j] += g * std::pow(z, j);
    }
  }
  for (const MomentMapFormat format : kFormats) {
    absl::StatusOr<MomentDepthMapBuilder> builder = MakeBuilder(geometry, 1.0, format);
    ASSERT_THAT(builder.status(), IsOk());
    MomentDepthMap map;
    ASSERT_THAT(builder->Build(depth, &map), IsOk());
    EXPECT_EQ(map.invalid_depths, geometry.height + 1);
    const PowerMomentsF b = map.Texel(cx, cy);
    const double tolerance = format == MomentMapFormat::kOptimized64 ? 6e-5 : kMomentTolerance;
    for (int j = 0; j < kPowerMomentCount; ++j) {
      EXPECT_NEAR(b[j], sum[j] / sum[0], tolerance) << Name(format) << " b_" << j;
    }
  }
}

TEST(MomentDepthMapBuilder, AllNaNFootprintGivesTheFarPlaneAndCountsAsEmpty) {
  // A 10 x 8 NaN block and sigma 1 (radius 3): the inner 4 x 2 texels see no valid depth.
  const ImageGeometry geometry{20, 16};
  std::vector<float> depth(static_cast<size_t>(geometry.pixel_count()), 1.0f);
  for (int y = 4; y < 12; ++y) {
    for (int x = 5; x < 15; ++x) depth[static_cast<size_t>(y * geometry.width + x)] = kNaNf;
  }
  for (const MomentMapFormat format : kFormats) {
    absl::StatusOr<MomentDepthMapBuilder> builder = MakeBuilder(geometry, 1.0, format);
    ASSERT_THAT(builder.status(), IsOk());
    MomentDepthMap map;
    ASSERT_THAT(builder->Build(depth, &map), IsOk());
    EXPECT_EQ(map.invalid_depths, 80);
    EXPECT_EQ(map.empty_texels, 8) << Name(format);
    for (int y = 7; y < 9; ++y) {
      for (int x = 8; x < 12; ++x) {
        const PowerMomentsF b = map.Texel(x, y);
        for (int j = 0; j < kPowerMomentCount; ++j) EXPECT_NEAR(b[j], 1.0f, 6e-5) << j;
        // The far plane hides nothing in front of `far`, and hides a fragment behind it.
        EXPECT_LE(map.Occlusion(x, y, 4.0), 1e-3) << Name(format);
        EXPECT_GE(map.Occlusion(x, y, 6.0), 0.99) << Name(format);
      }
    }
    // A texel with one valid pixel at the edge of its footprint answers from that pixel alone.
    EXPECT_GE(map.Occlusion(7, 7, 2.0), 0.99) << Name(format);
  }
}

TEST(MomentDepthMapBuilder, OutOfRangeDepthIsClampedToTheNearerEndAndCounted) {
  const ImageGeometry geometry{4, 2};
  const std::vector<float> depth = {0.1f, 0.5f, 2.5f, 4.5f, 9.0f, -3.0f, 1e30f, kInfF};
  for (const MomentMapFormat format : kFormats) {
    absl::StatusOr<MomentDepthMapBuilder> builder = MakeBuilder(geometry, 0.0, format);
    ASSERT_THAT(builder.status(), IsOk());
    MomentDepthMap map, reference;
    ASSERT_THAT(builder->Build(depth, &map), IsOk());
    ASSERT_THAT(builder->BuildReference(depth, &reference), IsOk());
    EXPECT_EQ(map.clamped_depths, 4) << Name(format);  // 0.1, 9, -3, 1e30; near and far are in
    EXPECT_EQ(map.invalid_depths, 1) << Name(format);  // infinity
    ExpectEqualCounts(map, reference);
    EXPECT_NEAR(map.Texel(0, 0)[1], -1.0f, 6e-5);  // 0.1 m -> near
    EXPECT_NEAR(map.Texel(0, 1)[1], 1.0f, 6e-5);   // 9 m -> far
    EXPECT_NEAR(map.Texel(1, 1)[1], -1.0f, 6e-5);  // -3 m -> near
    EXPECT_NEAR(map.Texel(2, 1)[1], 1.0f, 6e-5);   // 1e30 m -> far
  }
}

TEST(MomentDepthMapBuilder, OutputIsNeverNaN) {
  const ImageGeometry geometry{16, 14};
  std::mt19937_64 rng(12);
  const std::vector<float> specials = {kNaNf, kInfF,  -kInfF, 1e38f, -1e38f,
                                       0.0f,  1e-38f, 0.5f,   4.5f,  2.0f};
  std::vector<float> depth(static_cast<size_t>(2 * geometry.pixel_count())), weight(depth.size());
  for (size_t i = 0; i < depth.size(); ++i) {
    depth[i] = specials[rng() % specials.size()];
    weight[i] = specials[rng() % specials.size()];  // also negative, zero and huge weights
  }
  const std::span<const float> first(depth.data(), depth.size() / 2);
  for (const MomentMapFormat format : kFormats) {
    for (const double sigma : {0.0, 1.0}) {
      absl::StatusOr<MomentDepthMapBuilder> builder = MakeBuilder(geometry, sigma, format);
      ASSERT_THAT(builder.status(), IsOk());
      MomentDepthMap maps[4];
      ASSERT_THAT(builder->Build(first, &maps[0]), IsOk());
      ASSERT_THAT(builder->BuildReference(first, &maps[1]), IsOk());
      ASSERT_THAT(builder->BuildFromReturns(2, depth, weight, &maps[2]), IsOk());
      ASSERT_THAT(builder->BuildFromReturnsReference(2, depth, weight, &maps[3]), IsOk());
      for (const MomentDepthMap& map : maps) {
        for (const float m : map.moments) ASSERT_TRUE(std::isfinite(m));
        for (int y = 0; y < geometry.height; ++y) {
          for (int x = 0; x < geometry.width; ++x) {
            for (const double q : {double{kNaNf}, -1e300, 0.0, 2.0, 1e300, double{kInfF}}) {
              const float o = map.Occlusion(x, y, q);
              ASSERT_TRUE(o >= 0.0f && o <= 1.0f) << o << " at depth " << q;
            }
            ASSERT_EQ(map.Occlusion(x, y, kNaNf), 0.0f);
          }
        }
      }
    }
  }
}

// ---- mixed pixels (prop. 2.12) -----------------------------------------------------------------

// Two surfaces d1 < d2 in one pixel: their moments are on the boundary of the moment space
// (prop. 2.12, singular Hankel matrix), so the sharp bound between them is exactly the weight
// in front. The bias (eq. 4.2) raises it by at most α and lowers it by at most the weight the
// biased solution puts on the query itself, w_0 <= ξ4' / P(z_f)² with P(z) = (z - d1)(z - d2)
// and ξ4' ≈ α E_{b*}[P²] (power_moments_test's TwoSurfaceLeak); twice that allows for O(α²).
double TwoSurfaceLeak(double d1, double d2, double z_f, const MomentBias& bias) {
  auto p2 = [&](double z) { return std::pow((z - d1) * (z - d2), 2); };
  // b* = (1, 0, s, 0, s) is the moment vector of (1 - s) δ_0 + (s / 2) (δ_-1 + δ_1).
  const double s = bias.b_star_even;
  const double expected = (1.0 - s) * p2(0.0) + 0.5 * s * (p2(-1.0) + p2(1.0));
  return 2.0 * bias.alpha * expected / p2(z_f);
}

TEST(MomentDepthMapBuilder, TwoSurfaceMixedPixelGivesTheExactFractions) {
  // Returns at 1.5 m (z̄ = -0.5, weight 0.3) and 3.5 m (z̄ = 0.5, weight 0.7), no filter.
  const ImageGeometry geometry{3, 2};
  const size_t n = static_cast<size_t>(geometry.pixel_count());
  std::vector<float> depth(2 * n), weight(2 * n);
  for (size_t p = 0; p < n; ++p) {
    depth[p] = 1.5f, weight[p] = 0.3f;
    depth[n + p] = 3.5f, weight[n + p] = 0.7f;
  }
  // 64-bit: codes round Θ by half a code (7.6e-6), moving b by up to 3.5 times that, 2.7e-5 --
  // half of α = 6e-5: allowed as another 0.5 α on top of the bias terms.
  for (const MomentMapFormat format : kFormats) {
    const MomentBias bias =
        format == MomentMapFormat::kOptimized64 ? kQuantized16MomentBias : kFloatMomentBias;
    const double rounding = format == MomentMapFormat::kOptimized64 ? 0.5 * bias.alpha : 1e-6;
    absl::StatusOr<MomentDepthMapBuilder> builder = MakeBuilder(geometry, 0.0, format);
    ASSERT_THAT(builder.status(), IsOk());
    MomentDepthMap map;
    ASSERT_THAT(builder->BuildFromReturns(2, depth, weight, &map), IsOk());
    EXPECT_EQ(map.invalid_depths, 0);
    for (int y = 0; y < geometry.height; ++y) {
      for (int x = 0; x < geometry.width; ++x) {
        for (const double q : {2.0, 2.5, 3.0}) {  // between: z̄ = -0.25, 0, 0.25
          const double between = map.Occlusion(x, y, q);
          const double leak = TwoSurfaceLeak(-0.5, 0.5, kRange.Normalise(q), bias);
          EXPECT_LE(between, 0.3 + bias.alpha + rounding) << Name(format) << " " << q;
          EXPECT_GE(between, 0.3 - leak - rounding) << Name(format) << " " << q;
        }
        for (const double q : {0.5, 1.0, 1.25}) {  // in front of both
          EXPECT_LE(map.Occlusion(x, y, q), bias.alpha + rounding) << Name(format) << " " << q;
        }
        for (const double q : {3.75, 4.0, 4.5}) {  // behind both
          const double leak = TwoSurfaceLeak(-0.5, 0.5, kRange.Normalise(q), bias);
          EXPECT_GE(map.Occlusion(x, y, q), 1.0 - leak - rounding) << Name(format) << " " << q;
        }
      }
    }
  }
}

}  // namespace
}  // namespace transient
