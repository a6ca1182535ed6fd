// The products of a solved frame: each plane is its kernel's, computed only when needed; the
// flags say why a range is missing; depth is range along the pixel's ray; the Pisarenko range
// comes whatever the range method.
#include "transient/reconstruct/frame_products.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "tests/reconstruct/test_measures.h"
#include "transient/reconstruct/physical_constants.h"

namespace transient {
namespace {

constexpr ImageGeometry kGeometry{.width = 6, .height = 4};
constexpr double kFrequencyHz = 20e6;

// Pixel p: two returns, the first at phase 0.4 + 0.1 p; pixel 5 invalid (NaN moments), pixel 7
// nothing but a uniform part (no return above any threshold).
std::shared_ptr<const SolvedImage> MakeSolved(int m) {
  MomentImage image(kGeometry, m);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> w(0.5, 1.0);
  for (int64_t p = 0; p < kGeometry.pixel_count(); ++p) {
    testing::SparseMeasure measure;
    if (p != 7) {
      measure.phase = {0.4 + 0.1 * p, 0.4 + 0.1 * p + 2.0};
      measure.weight = {w(rng), 0.4 * w(rng)};
    }
    measure.uniform = p == 7 ? 1.0 : 0.05;
    const std::vector<Complex> c = measure.Moments(m);
    for (int j = 0; j <= m; ++j) {
      image.real_plane(j)[p] = p == 5 ? kNaNf : static_cast<float>(c[j].real());
      image.imag_plane(j)[p] = static_cast<float>(c[j].imag());
    }
  }
  return std::make_shared<SolvedImage>(Solve(image, SolveOptions{}));
}

CameraInfo Camera() {
  CameraInfo camera;
  camera.geometry = kGeometry;
  camera.intrinsics = {.fx = 5.0, .fy = 5.0, .cx = 2.5, .cy = 1.5};
  return camera;
}

TEST(FrameProducts, OnlyWhatIsNeededIsComputed) {
  const auto products = ComputeProducts(MakeSolved(3), Camera(), {.base_frequency_hz = kFrequencyHz},
                                        ProductNeeds{.c0 = true}, 17);
  EXPECT_EQ(products->sequence, 17u);
  EXPECT_EQ(products->c0.size(), static_cast<size_t>(kGeometry.pixel_count()));
  EXPECT_TRUE(products->range_m.empty());
  EXPECT_TRUE(products->depth_m.empty());
  EXPECT_TRUE(products->amplitude.empty());
  EXPECT_EQ(products->pisarenko, nullptr);
  EXPECT_TRUE(std::isnan(products->c0[5])) << "an invalid pixel has no c_0";
  EXPECT_EQ(products->flags, products->solved->flags) << "no range: the solver's flags";
}

TEST(FrameProducts, RangeIsTheFirstReturnAndTheFlagsSayWhereThereIsNone) {
  for (RangeMethod method : {RangeMethod::kMese, RangeMethod::kPisarenko}) {
    const auto products = ComputeProducts(
        MakeSolved(3), Camera(),
        {.base_frequency_hz = kFrequencyHz, .range_method = method, .threshold = 0.1},
        ProductNeeds{.range = true});
    for (int64_t p = 0; p < kGeometry.pixel_count(); ++p) {
      const float range = products->range_m[p];
      const uint8_t flags = products->flags[p];
      EXPECT_EQ(std::isnan(range), (flags & (kFlagInvalidInput | kFlagNoReturn)) != 0) << p;
      if (p == 5) {
        EXPECT_NE(flags & kFlagInvalidInput, 0);
      }
      if (p == 5 || p == 7) continue;
      EXPECT_NEAR(range, PhaseToRange(0.4 + 0.1 * p, kFrequencyHz), 0.02) << p;
    }
    EXPECT_NE(products->flags[7] & kFlagNoReturn, 0) << "a uniform part has no return";
    EXPECT_EQ(products->pisarenko != nullptr, method == RangeMethod::kPisarenko);
  }
}

TEST(FrameProducts, TheDepthIsTheRangeAlongThePixelsRay) {
  const CameraInfo camera = Camera();
  const auto products = ComputeProducts(MakeSolved(3), camera, {.base_frequency_hz = kFrequencyHz},
                                        ProductNeeds{.depth = true});
  ASSERT_EQ(products->depth_m.size(), products->range_m.size()) << "depth needs the range";
  for (int64_t p = 0; p < kGeometry.pixel_count(); ++p) {
    const double z = PixelRay(camera.intrinsics, p % kGeometry.width, p / kGeometry.width).z;
    if (std::isnan(products->range_m[p])) {
      EXPECT_TRUE(std::isnan(products->depth_m[p])) << p;
    } else {
      EXPECT_FLOAT_EQ(products->depth_m[p], static_cast<float>(products->range_m[p] * z)) << p;
      EXPECT_LT(products->depth_m[p], products->range_m[p]) << "off the axis Z < range";
    }
  }
}

TEST(FrameProducts, ThePisarenkoRangeComesWhateverTheRangeMethod) {
  const auto products = ComputeProducts(
      MakeSolved(3), Camera(), {.base_frequency_hz = kFrequencyHz, .range_method = RangeMethod::kMese},
      ProductNeeds{.range = true, .pisarenko = true, .pisarenko_range = true});
  ASSERT_NE(products->pisarenko, nullptr);
  ASSERT_EQ(products->pisarenko_range_m.size(), products->range_m.size());
  for (int64_t p : {0, 3, 11, 23}) {
    EXPECT_NEAR(products->pisarenko_range_m[p], PhaseToRange(0.4 + 0.1 * p, kFrequencyHz), 1e-3)
        << "Pisarenko is exact on two Diracs and a uniform part, pixel " << p;
    EXPECT_NEAR(products->range_m[p], products->pisarenko_range_m[p], 0.02) << p;
  }
}

TEST(FrameProducts, SlicesAreComputedOncePerPhaseListAndKind) {
  const std::vector<double> phases = UniformPhases(8);
  ProductNeeds needs;
  needs.slice_phases[phases] = {.density = true, .cumulative = false};
  const auto solved = MakeSolved(3);
  const auto products = ComputeProducts(solved, Camera(), {.base_frequency_hz = kFrequencyHz}, needs);
  ASSERT_EQ(products->slices.size(), 1u);
  const SliceImages& slices = products->slices.at(phases);
  EXPECT_TRUE(slices.cumulative.empty());
  std::vector<float> expected(phases.size() * kGeometry.pixel_count());
  DensitySlices(*solved, phases, expected);
  EXPECT_EQ(slices.density.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    if (std::isnan(expected[i])) {
      EXPECT_TRUE(std::isnan(slices.density[i]));
    } else {
      EXPECT_EQ(slices.density[i], expected[i]);
    }
  }
}

TEST(FrameProducts, MomentDepthBuildersAreKeptAcrossFramesAndDroppedWithTheirSpecs) {
  const auto solved = MakeSolved(3);
  const MomentDepthSpec of_depth{.near_m = 0.0, .far_m = 8.0, .sigma_px = 0.0};
  const MomentDepthSpec of_returns{.near_m = 0.0, .far_m = 8.0, .sigma_px = 0.0,
                                   .from_returns = true};
  const MomentDepthSpec invalid{.near_m = 0.0, .far_m = 8.0, .sigma_px = 100.0};  // wider than 6x4
  const ProductNeeds needs{.moment_depth = {of_depth, of_returns, invalid}};
  const ProductOptions options{.base_frequency_hz = kFrequencyHz};
  MomentDepthBuilders builders;
  const auto first = ComputeProducts(solved, Camera(), options, needs, 0, &builders);
  EXPECT_EQ(builders.size(), 3u);  // the invalid spec's refusal is kept too
  MomentDepthMapBuilder* kept = builders.For(kGeometry, of_depth);
  ASSERT_NE(kept, nullptr);
  EXPECT_EQ(builders.For(kGeometry, invalid), nullptr);
  const auto second = ComputeProducts(solved, Camera(), options, needs, 1, &builders);
  EXPECT_EQ(builders.For(kGeometry, of_depth), kept) << "the same builder, frame after frame";
  // Kept builders give the maps that builders made for the frame give.
  const auto fresh = ComputeProducts(solved, Camera(), options, needs);
  for (const auto* products : {first.get(), second.get()}) {
    ASSERT_EQ(products->moment_depth.size(), 2u) << "no map for the invalid spec";
    for (const MomentDepthSpec& spec : {of_depth, of_returns}) {
      EXPECT_EQ(products->moment_depth.at(spec)->quantized, fresh->moment_depth.at(spec)->quantized);
    }
  }
  // Another geometry gets another builder; specs no longer asked for lose theirs.
  const ImageGeometry other{.width = 3, .height = 2};
  MomentDepthMapBuilder* resized = builders.For(other, of_depth);
  ASSERT_NE(resized, nullptr);
  EXPECT_EQ(resized->geometry(), other);
  (void)ComputeProducts(solved, Camera(), options, ProductNeeds{.moment_depth = {of_returns}}, 2,
                        &builders);
  EXPECT_EQ(builders.size(), 1u);
  (void)ComputeProducts(solved, Camera(), options, ProductNeeds{.c0 = true}, 3, &builders);
  EXPECT_EQ(builders.size(), 0u);
}

TEST(DepthProducts, TheGivenDepthWithItsRangeAndFlagsWhereThereIsNone) {
  const CameraInfo camera = Camera();
  const size_t n = static_cast<size_t>(kGeometry.pixel_count());
  std::vector<float> depth(n), amplitude(n);
  for (size_t p = 0; p < n; ++p) {
    depth[p] = 1.0f + 0.25f * static_cast<float>(p);
    amplitude[p] = 100.0f + static_cast<float>(p);
  }
  depth[2] = kNaNf;
  depth[3] = 0.0f;
  depth[4] = -2.0f;
  depth[6] = std::numeric_limits<float>::infinity();
  const MomentDepthSpec spec{.near_m = 0.0, .far_m = 8.0, .sigma_px = 0.0};
  const auto products = ComputeDepthProducts(
      depth, amplitude, camera, ProductNeeds{.amplitude = true, .moment_depth = {spec}}, 9);
  EXPECT_EQ(products->sequence, 9u);
  EXPECT_EQ(products->solved, nullptr);
  EXPECT_EQ(products->amplitude, amplitude);
  EXPECT_TRUE(products->moment_depth.contains(spec));
  for (size_t p = 0; p < n; ++p) {
    const bool none = p == 2 || p == 3 || p == 4 || p == 6;
    EXPECT_EQ(products->flags[p], none ? kFlagNoReturn : 0) << p;
    if (none) {
      EXPECT_TRUE(std::isnan(products->depth_m[p])) << p;
      EXPECT_TRUE(std::isnan(products->range_m[p])) << p;
      continue;
    }
    EXPECT_EQ(products->depth_m[p], depth[p]) << p;
    const double z = PixelRay(camera.intrinsics, static_cast<double>(p % kGeometry.width),
                              static_cast<double>(p / kGeometry.width)).z;
    EXPECT_FLOAT_EQ(products->range_m[p], static_cast<float>(depth[p] / z)) << p;
  }
  // No amplitude frame: none, whatever is needed.
  EXPECT_TRUE(ComputeDepthProducts(depth, {}, camera, ProductNeeds{.amplitude = true})
                  ->amplitude.empty());
}

TEST(MergeNoReturn, AnUnexplainedNanIsANoReturnAndInvalidPixelsKeepTheirReason) {
  const std::vector<uint8_t> solved = {0, kFlagInvalidInput, 0, kFlagBiased};
  const std::vector<uint8_t> range_flags = {0, kFlagInvalidInput, kFlagNoReturn, kFlagBiased};
  const std::vector<float> range = {1.0f, kNaNf, kNaNf, kNaNf};
  std::vector<uint8_t> out(4);
  MergeNoReturn(solved, range_flags, range, out);
  EXPECT_EQ(out[0], 0);
  EXPECT_EQ(out[1], kFlagInvalidInput);
  EXPECT_EQ(out[2], kFlagNoReturn);
  EXPECT_EQ(out[3], kFlagBiased | kFlagNoReturn);
}

}  // namespace
}  // namespace transient
