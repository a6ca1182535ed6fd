// The optimized kernels against the scalar reference, on random valid frames, with the
// accuracy contract of the optimized kernels: density relative error <= 1e-3 wherever
// D >= 1e-3 max D, cumulative error <= 1e-4 c_0, range within 0.1 mm, identical flags,
// Pisarenko's returns the same with phases within 1e-5 rad and masses within 1e-5 c_0. Orders
// 1, 3, 4, 8, 16 and 10 (the range kernel zero-pads it to 12, or to 16 under the sanitizers).
#include "transient/reconstruct/kernels.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <complex>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <numbers>
#include <random>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "reconstruct/kernels_internal.h"
#include "reconstruct/kernels_simd.h"
#include "test_measures.h"
#include "transient/reconstruct/mese.h"
#include "transient/reconstruct/pisarenko.h"
#include "transient/reconstruct/range.h"

namespace transient {
namespace {

constexpr double kDensityTolerance = 1e-3;     // relative, where D >= 1e-3 max D
constexpr double kDensityFloor = 1e-3;         // of the pixel's largest sample
constexpr double kCumulativeTolerance = 1e-4;  // relative to c_0
constexpr double kRangeTolerance = 1e-4;       // metres
constexpr double kPisarenkoPhaseTolerance = 1e-5;  // radians
constexpr double kPisarenkoMassTolerance = 1e-5;   // relative to c_0
constexpr ImageGeometry kGeometry{37, 23};     // not a multiple of any block or vector size

// Pixels with 1..m+1 returns, a uniform part from 0 to 0.2, noise (of standard deviation
// `noise` per moment) that makes some of them need biasing, a few invalid ones (NaN, no light,
// masked) and one of uniform light alone.
MomentImage RandomFrame(int m, uint64_t seed, double noise_sigma = 0.01) {
  std::mt19937_64 rng(seed);
  MomentImage image(kGeometry, m);
  const int64_t pixels = kGeometry.pixel_count();
  image.valid.assign(pixels, 1);
  std::uniform_real_distribution<double> uniform(0.0, 0.2);
  std::normal_distribution<double> noise(0.0, noise_sigma);
  for (int64_t p = 0; p < pixels; ++p) {
    const int count = 1 + static_cast<int>(rng() % (m + 1));
    const auto measure = testing::RandomSparseMeasure(count, 0.05, uniform(rng), rng);
    std::vector<Complex> c = measure.Moments(m);
    for (int j = 1; j <= m; ++j) c[j] += Complex(noise(rng), noise(rng));
    for (int j = 0; j <= m; ++j) {
      image.real_plane(j)[p] = static_cast<float>(c[j].real());
      image.imag_plane(j)[p] = static_cast<float>(c[j].imag());
    }
  }
  image.real_plane(1)[3] = std::nanf("");
  image.real_plane(0)[7] = 0.0f;
  image.valid[11] = 0;
  for (int j = 1; j <= m; ++j) {  // uniform light alone: a flat density, no peak
    image.real_plane(j)[13] = 0.0f;
    image.imag_plane(j)[13] = 0.0f;
  }
  return image;
}

class Kernels : public ::testing::TestWithParam<int> {
 protected:
  void SetUp() override { SetKernelOptions({.kind = KernelKind::kOptimized, .threads = 2}); }
  void TearDown() override { SetKernelOptions({}); }
};

// Equal bit for bit, or both NaN; the count of values that are not.
int64_t CountUnequalBits(const std::vector<double>& got, const std::vector<double>& expected) {
  EXPECT_EQ(got.size(), expected.size());
  int64_t unequal = 0;
  for (size_t i = 0; i < got.size() && i < expected.size(); ++i) {
    const bool both_nan = std::isnan(got[i]) && std::isnan(expected[i]);
    unequal += !both_nan && std::bit_cast<uint64_t>(got[i]) != std::bit_cast<uint64_t>(expected[i]);
  }
  return unequal;
}

TEST_P(Kernels, SolveMatchesTheReferenceWithIdenticalFlags) {
  const int m = GetParam();
  // The usual frame, and one whose noise takes most pixels far past the moment set, where
  // biasing's search below zero takes more steps. (In neither does a pixel reach Gershgorin's
  // start, collapse its bracket or run out of steps: the SolveLanes tests below have those.)
  for (const double noise : {0.01, 0.2}) {
    const MomentImage image = RandomFrame(m, 100 + m, noise);
    for (const BiasMode mode : {BiasMode::kRaiseZeroth, BiasMode::kScaleMoments}) {
      SCOPED_TRACE(absl::StrCat(mode == BiasMode::kRaiseZeroth ? "raise c_0" : "scale c_1..c_m",
                                ", noise ", noise));
      const SolveOptions options{.bias_mode = mode};
      const SolvedImage expected = reference::Solve(image, options);
      const SolvedImage got = optimized::Solve(image, options);
      ASSERT_EQ(got.flags, expected.flags);
      int biased = 0;
      for (uint8_t f : got.flags) biased += (f & kFlagBiased) != 0;
      EXPECT_GT(biased, 0) << "the frame should exercise biasing";
      if (noise < 0.1) {
        EXPECT_LT(biased, kGeometry.pixel_count()) << "and the quick check";
      }
      EXPECT_EQ(CountUnequalBits(got.c_real, expected.c_real), 0);
      EXPECT_EQ(CountUnequalBits(got.c_imag, expected.c_imag), 0);
      EXPECT_EQ(CountUnequalBits(got.q_real, expected.q_real), 0);
      EXPECT_EQ(CountUnequalBits(got.q_imag, expected.q_imag), 0);

      // Biasing's lambda_min in SIMD lanes for m <= 8 (under the sanitizers the lanes are
      // compiled for m = 1, 3, 4 and 8 only: the orders this suite runs); the pixels the lanes
      // cannot vouch for, and every pixel above m = 8, one by one.
      SolvedImage lanes;
      internal::PrepareSolved(image, &lanes);
      const int64_t decided =
          internal::SolveBlock(image, options, 0, kGeometry.pixel_count(), &lanes);
      RecordProperty(absl::StrCat("lane_biasing_", static_cast<int>(mode), "_noise_", noise),
                     absl::StrCat(decided, " decided in lanes; ", biased, " biased"));
      EXPECT_EQ(lanes.flags, expected.flags);
      EXPECT_EQ(CountUnequalBits(lanes.c_real, expected.c_real), 0);
      EXPECT_EQ(CountUnequalBits(lanes.c_imag, expected.c_imag), 0);
      EXPECT_EQ(CountUnequalBits(lanes.q_real, expected.q_real), 0);
      EXPECT_EQ(CountUnequalBits(lanes.q_imag, expected.q_imag), 0);
      if (m <= 8) {
        EXPECT_GE(decided, 0.9 * biased) << "m = " << m;
      } else {
        EXPECT_EQ(decided, 0) << "m = " << m;
      }
    }
  }
}

// Moments whose search below zero fails down to Gershgorin's bound: c = (1, 5, 0, ..., 0), whose
// leading 2 x 2 minor has lambda_min = -4, so that C - shift I fails the recursion at 0,
// -1/64, ..., -4, and -16 is below the bound (1 - 10). ToeplitzLambdaMin then starts from the
// bound; the solve's lanes leave such pixels to the per-pixel path, whose results are the
// reference's. (At m = 1 there is no leading minor to fail: the start at 0 passes.)
TEST(SolveLanes, LeaveBiasingFromGershgorinsBoundToThePerPixelPath) {
  for (const int m : {3, 4, 8}) {  // orders whose lanes are compiled under the sanitizers too
    SCOPED_TRACE(absl::StrCat("m = ", m));
    const ImageGeometry geometry{16, 1};
    MomentImage image(geometry, m);
    for (int64_t p = 0; p < geometry.pixel_count(); ++p) {
      for (int j = 0; j <= m; ++j) {
        image.real_plane(j)[p] = j == 0 ? 1.0f : j == 1 ? 5.0f : 0.0f;
        image.imag_plane(j)[p] = 0.0f;
      }
    }
    const SolvedImage expected = reference::Solve(image, SolveOptions{});
    SolvedImage lanes;
    internal::PrepareSolved(image, &lanes);
    const int64_t decided =
        internal::SolveBlock(image, SolveOptions{}, 0, geometry.pixel_count(), &lanes);
    EXPECT_EQ(decided, 0);
    EXPECT_EQ(lanes.flags, expected.flags);
    EXPECT_EQ(lanes.flags[0], kFlagBiased);
    EXPECT_EQ(CountUnequalBits(lanes.c_real, expected.c_real), 0);
    EXPECT_EQ(CountUnequalBits(lanes.q_real, expected.q_real), 0);
    EXPECT_EQ(CountUnequalBits(lanes.q_imag, expected.q_imag), 0);
  }
}

// Moments far past the moment set (c_0 a thousandth or less of |c_j|, as noise could make of a
// dark pixel) whose lambda_min ToeplitzLambdaMin's search below zero ends in the two ways that
// random frames never reach (a search over 1.8 M random vectors found these):
// - a collapsed bracket (c_0 ~ 1e-4): Newton's step leaves a bracket narrower than the
//   tolerance, and lambda_min is the bracket's middle, eigenvector-like: the lanes vouch;
// - the step limit (c_0 of 4e-6 and below): the tolerance, kToeplitzLambdaTolerance c_0, is below
//   the rounding of lambda_min ~ -1, so Newton's steps never get under it and the scalar code
//   declines after kToeplitzLambdaMaxSteps recursions: so do the lanes, for the per-pixel path.
// Two of each per order, cyclically over the 16 pixels, so that the lanes of one vector end in
// different ways; every result bit for bit the reference's. (Which exit a pixel takes is not
// visible from outside; lanes changed to give another value at a collapsed bracket, or to vouch
// at the step limit, fail this test.)
TEST(SolveLanes, FollowTheScalarSearchToACollapsedBracketAndToItsStepLimit) {
  using Moments = std::vector<std::complex<float>>;
  struct Order {
    int m;
    std::vector<Moments> collapsed, step_limit;
  };
  const std::vector<Order> orders = {
      {3,
       {{{0.000125718303f, 0.0f},
         {0.269875675f, 0.00324794254f},
         {0.122146212f, 0.118517525f},
         {-0.458267599f, 0.467290074f}},
        {{0.000132199173f, 0.0f},
         {0.384019315f, -0.199481055f},
         {-0.266842455f, -0.125648245f},
         {-0.101782702f, 0.478893042f}}},
       {{{1.27122507e-06f, 0.0f},
         {-0.159219727f, -0.417188078f},
         {-0.463278025f, 0.0642449409f},
         {0.312678397f, 0.486924499f}},
        {{2.28486852e-09f, 0.0f},
         {0.340172917f, 0.0790213272f},
         {0.280617833f, 0.169090167f},
         {-0.464614242f, 0.22212182f}}}},
      {4,
       {{{0.000117583062f, 0.0f},
         {0.0233230758f, -0.416335642f},
         {-0.41708383f, -0.276463658f},
         {0.422964722f, 0.344018906f},
         {0.331299216f, -0.217356294f}},
        {{0.000112575624f, 0.0f},
         {0.133488968f, -0.248291746f},
         {-0.0274520144f, -0.00166879117f},
         {0.197728753f, 0.317791313f},
         {0.435137391f, -0.14361085f}}},
       {{{1.92812184e-08f, 0.0f},
         {0.300866991f, -0.486310124f},
         {0.0287920963f, 0.0870540291f},
         {0.415006429f, -0.082201384f},
         {0.0532497242f, -0.111437269f}},
        {{7.17409932e-07f, 0.0f},
         {-0.147720888f, 0.264627725f},
         {-0.355538219f, 0.139570981f},
         {0.0451472588f, -0.140093416f},
         {-0.290351748f, 0.318747818f}}}},
      {8,
       {{{0.000407226849f, 0.0f},
         {0.0472123027f, -0.261005253f},
         {-0.108022422f, -0.310607523f},
         {0.113935329f, 0.201170534f},
         {0.108667575f, 0.380708426f},
         {-0.224628627f, 0.289818645f},
         {-0.246455461f, -0.138697207f},
         {-0.248885483f, 0.25450635f},
         {0.497632384f, 0.429406345f}},
        {{0.000256246305f, 0.0f},
         {-0.10274069f, -0.00403562281f},
         {-0.302264512f, -0.240343496f},
         {-0.00262379763f, -0.126776546f},
         {-0.0770902485f, 0.0194907729f},
         {0.221315354f, 0.12500383f},
         {0.330951542f, 0.337402642f},
         {-0.424630225f, 0.081936948f},
         {-0.279760182f, -0.0969453007f}}},
       {{{3.80276879e-06f, 0.0f},
         {0.217031971f, -0.192746297f},
         {0.300414354f, 0.402042717f},
         {-0.177643582f, 0.420314997f},
         {-0.112317041f, -0.164336041f},
         {0.403600514f, -0.222959071f},
         {0.321765244f, -0.315924793f},
         {0.167742774f, 0.212740242f},
         {-0.319353044f, 0.438275546f}},
        {{1.96380623e-09f, 0.0f},
         {0.445314646f, -0.070285514f},
         {-0.227333099f, 0.0921122357f},
         {-0.248992458f, -0.189707503f},
         {-0.210756615f, -0.219997242f},
         {0.0827297121f, -0.120876618f},
         {0.11783275f, -0.253973365f},
         {0.393238008f, 0.23023954f},
         {-0.000188633654f, -0.174377307f}}}},
  };
  for (const Order& order : orders) {
    const int m = order.m;  // orders whose lanes are compiled under the sanitizers too
    std::vector<Moments> cycle = order.collapsed;
    cycle.insert(cycle.end(), order.step_limit.begin(), order.step_limit.end());
    const ImageGeometry geometry{16, 1};
    MomentImage image(geometry, m);
    int64_t collapsed = 0;
    for (int64_t p = 0; p < geometry.pixel_count(); ++p) {
      const size_t which = p % cycle.size();
      collapsed += which < order.collapsed.size();
      for (int j = 0; j <= m; ++j) {
        image.real_plane(j)[p] = cycle[which][j].real();
        image.imag_plane(j)[p] = cycle[which][j].imag();
      }
    }
    for (const BiasMode mode : {BiasMode::kRaiseZeroth, BiasMode::kScaleMoments}) {
      SCOPED_TRACE(absl::StrCat(
          "m = ", m, mode == BiasMode::kRaiseZeroth ? ", raise c_0" : ", scale c_1..c_m"));
      const SolveOptions options{.bias_mode = mode};
      const SolvedImage expected = reference::Solve(image, options);
      SolvedImage lanes;
      internal::PrepareSolved(image, &lanes);
      const int64_t decided =
          internal::SolveBlock(image, options, 0, geometry.pixel_count(), &lanes);
      EXPECT_EQ(decided, collapsed);  // the step limit's pixels go to the per-pixel path
      EXPECT_EQ(lanes.flags, expected.flags);
      for (int64_t p = 0; p < geometry.pixel_count(); ++p) {
        EXPECT_EQ(lanes.flags[p], kFlagBiased) << "pixel " << p;
      }
      EXPECT_EQ(CountUnequalBits(lanes.c_real, expected.c_real), 0);
      EXPECT_EQ(CountUnequalBits(lanes.c_imag, expected.c_imag), 0);
      EXPECT_EQ(CountUnequalBits(lanes.q_real, expected.q_real), 0);
      EXPECT_EQ(CountUnequalBits(lanes.q_imag, expected.q_imag), 0);
    }
  }
}

// The worst relative density error of the optimized kernel against the reference at
// `phases`, wherever D >= kDensityFloor x the pixel's largest sample; NaN pixels must match.
double WorstDensityError(const SolvedImage& solved, std::span<const double> phases) {
  const int64_t pixels = kGeometry.pixel_count();
  std::vector<float> expected(phases.size() * pixels), got(expected.size());
  reference::DensitySlices(solved, phases, expected);
  optimized::DensitySlices(solved, phases, got);
  double worst = 0.0;
  for (int64_t p = 0; p < pixels; ++p) {
    float peak = 0.0f;
    for (size_t n = 0; n < phases.size(); ++n) peak = std::max(peak, expected[n * pixels + p]);
    for (size_t n = 0; n < phases.size(); ++n) {
      const float e = expected[n * pixels + p], g = got[n * pixels + p];
      if (std::isnan(e)) {
        EXPECT_TRUE(std::isnan(g)) << "pixel " << p << " phase " << phases[n];
        continue;
      }
      if (e < kDensityFloor * peak) continue;
      worst = std::max(worst, std::abs(g - e) / static_cast<double>(e));
    }
  }
  return worst;
}

TEST_P(Kernels, DensityMeetsTheAccuracyContract) {
  const int m = GetParam();
  const SolvedImage solved = reference::Solve(RandomFrame(m, 200 + m), SolveOptions{});
  const double worst = WorstDensityError(solved, UniformPhases(1000));
  EXPECT_LE(worst, kDensityTolerance) << "m = " << m;
  RecordProperty("worst_relative_density_error", std::to_string(worst));
}

// The optimized kernel computes phi, -phi, pi + phi and pi - phi together where all four are
// asked for, the others one by one, and streams outputs of 8 MB or more past the caches:
// every case against the reference, on rows that are not aligned (37 x 23 pixels).
TEST_P(Kernels, DensityMeetsTheContractForAnyPhases) {
  const int m = GetParam();
  const SolvedImage solved = reference::Solve(RandomFrame(m, 250 + m), SolveOptions{});
  std::mt19937_64 rng(m);
  std::uniform_real_distribution<double> uniform(0.0, kTwoPi);
  std::vector<double> random(301);  // no symmetric partners
  for (double& phase : random) phase = uniform(rng);
  std::vector<double> mixed = UniformPhases(64);          // orbits, then phases without partners,
  for (int n = 0; n < 10; ++n) mixed.push_back(0.1 + n);  // partners across the wrap
  mixed.insert(mixed.end(), {-0.5, kTwoPi + 0.5, std::numbers::pi - 0.5, std::numbers::pi + 0.5});
  mixed.push_back(mixed[5]);  // a phase twice
  // Not phases at all: NaN densities, as the reference's, and the others unharmed.
  mixed.insert(mixed.end(), {std::nan(""), std::numeric_limits<double>::infinity()});
  const std::vector<std::pair<const char*, std::vector<double>>> cases = {
      {"uniform 2500 (streamed)", UniformPhases(2500)},
      {"uniform 7", UniformPhases(7)},
      {"random", random},
      {"mixed", mixed},
  };
  for (const auto& [name, phases] : cases) {
    const double worst = WorstDensityError(solved, phases);
    EXPECT_LE(worst, kDensityTolerance) << name << ", m = " << m;
  }
}

// The cumulative's lane logarithm and arctangent (optimized_cumulative_lanes.inc) against
// glibc's, at this CPU's level or TRANSIENT_SIMD's: within 4 units in the last place, over the
// exponents the closed form's |w|^2 can take and every quadrant of the right half-plane.
TEST(CumulativeLanes, LogAndArgAreGlibcsToFourUnitsInTheLastPlace) {
  std::vector<double> x, y;
  std::mt19937_64 random(17);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int e = -1000; e <= 1000; e += 7) {
    for (int k = 0; k < 8; ++k) {
      x.push_back(std::ldexp(1.0 + unit(random), e));
      y.push_back(std::ldexp(unit(random) - 0.5, e + static_cast<int>(unit(random) * 40) - 20));
    }
  }
  for (int k = 0; k < 4000; ++k) {  // near |w| = 1, and y / x near the reduction's bounds
    x.push_back(1.0 + std::ldexp(unit(random) - 0.5, -static_cast<int>(unit(random) * 50)));
    const double ratio =
        std::tan(std::numbers::pi / 16 * static_cast<int>(unit(random) * 8)) *
        (1.0 + std::ldexp(unit(random) - 0.5, -static_cast<int>(unit(random) * 50)));
    y.push_back((k % 2 == 0 ? 1.0 : -1.0) * ratio * x.back());
  }
  x.push_back(1.0), y.push_back(0.0);  // log 1 = 0 and atan 0 = 0 exactly
  x.push_back(std::numeric_limits<double>::min()), y.push_back(1.0);
  std::vector<double> log(x.size()), arg(x.size());
  internal::LogAndArgLanes(x.data(), y.data(), static_cast<int64_t>(x.size()), log.data(),
                           arg.data());
  const auto ulps = [](double got, double expected) {
    if (got == expected) return 0.0;
    const double unit = std::nextafter(std::abs(expected), INFINITY) - std::abs(expected);
    return std::abs(got - expected) / unit;
  };
  double worst_log = 0.0, worst_arg = 0.0;
  for (size_t i = 0; i < x.size(); ++i) {
    const double l = ulps(log[i], std::log(x[i])), a = ulps(arg[i], std::atan2(y[i], x[i]));
    EXPECT_LE(l, 4.0) << "log " << x[i] << ": " << log[i] << " against " << std::log(x[i]);
    EXPECT_LE(a, 4.0) << "atan2 " << y[i] << ", " << x[i] << ": " << arg[i] << " against "
                      << std::atan2(y[i], x[i]);
    worst_log = std::max(worst_log, l);
    worst_arg = std::max(worst_arg, a);
  }
  EXPECT_EQ(log[x.size() - 2], 0.0);
  EXPECT_EQ(arg[x.size() - 2], 0.0);
  RecordProperty("worst_log_ulps", absl::StrCat(worst_log));
  RecordProperty("worst_arg_ulps", absl::StrCat(worst_arg));
}

TEST_P(Kernels, CumulativeAndBoundsMatchTheReference) {
  const int m = GetParam();
  const SolvedImage solved = reference::Solve(RandomFrame(m, 300 + m), SolveOptions{});
  const int64_t pixels = kGeometry.pixel_count();
  // The worst difference from the reference relative to c_0, at `count` uniform phases.
  const auto worst_of = [&](int count) {
    const auto phases = UniformPhases(count);
    std::vector<float> expected(phases.size() * pixels), got(expected.size());
    reference::CumulativeSlices(solved, phases, expected);
    optimized::CumulativeSlices(solved, phases, got);
    double worst = 0.0;
    for (size_t i = 0; i < got.size(); ++i) {
      const int64_t p = static_cast<int64_t>(i) % pixels;
      if (std::isnan(expected[i])) {
        EXPECT_TRUE(std::isnan(got[i]));
      } else {
        EXPECT_NEAR(got[i], expected[i], kCumulativeTolerance * solved.c0(p)) << count;
        worst = std::max(worst, std::abs(got[i] - expected[i]) / solved.c0(p));
      }
    }
    return worst;
  };
  // 17 phases: whole vectors of the lanes, then Evaluate for the rest; 16: no phase left.
  RecordProperty("worst_cumulative_error_of_c0", absl::StrCat(worst_of(17)));
  RecordProperty("worst_cumulative_error_of_c0_16_phases", absl::StrCat(worst_of(16)));
  const auto phases = UniformPhases(17);
  const size_t size = phases.size() * pixels;
  std::vector<float> lower(size), upper(size), ref_lower(size), ref_upper(size);
  reference::BoundSlices(solved, 0.8, phases, ref_lower, ref_upper);
  optimized::BoundSlices(solved, 0.8, phases, lower, upper);
  for (size_t i = 0; i < size; ++i) {
    EXPECT_TRUE(lower[i] == ref_lower[i] || (std::isnan(lower[i]) && std::isnan(ref_lower[i])));
    EXPECT_TRUE(upper[i] == ref_upper[i] || (std::isnan(upper[i]) && std::isnan(ref_upper[i])));
  }
}

// The fast route's results (PisarenkoByLevinson, with the reference where it declines) against
// the reference's: the same returns, phases within kPisarenkoPhaseTolerance (1e-5 rad is 10 µm
// of range at 23 MHz), weights and the uniform part within kPisarenkoMassTolerance of c_0. On
// these frames the fast route must take most pixels, or it would test nothing.
TEST_P(Kernels, PisarenkoMeetsTheAccuracyContract) {
  const int m = GetParam();
  const SolvedImage solved = reference::Solve(RandomFrame(m, 300 + m), SolveOptions{});
  const int64_t pixels = kGeometry.pixel_count();
  const PisarenkoImage a = reference::EstimatePisarenko(solved);
  const PisarenkoImage b = optimized::EstimatePisarenko(solved);
  double worst_phase = 0.0, worst_mass = 0.0;
  for (int64_t p = 0; p < pixels; ++p) {
    if (std::isnan(a.uniform[p])) {
      EXPECT_TRUE(std::isnan(b.uniform[p])) << "pixel " << p;
      continue;
    }
    const double c0 = solved.c0(p);
    worst_mass = std::max(worst_mass, std::abs(b.uniform[p] - a.uniform[p]) / c0);
    for (int l = 0; l < m; ++l) {
      const float pa = a.phase[l * pixels + p], pb = b.phase[l * pixels + p];
      const float wa = a.weight[l * pixels + p], wb = b.weight[l * pixels + p];
      ASSERT_EQ(std::isnan(pa), std::isnan(pb)) << "pixel " << p << " return " << l;
      if (std::isnan(pa)) continue;
      const double d = std::abs(pb - pa);
      worst_phase = std::max(worst_phase, std::min(d, kTwoPi - d));
      worst_mass = std::max(worst_mass, std::abs(wb - wa) / c0);
    }
  }
  EXPECT_LE(worst_phase, kPisarenkoPhaseTolerance) << "m = " << m;
  EXPECT_LE(worst_mass, kPisarenkoMassTolerance) << "m = " << m;
  RecordProperty("worst_phase_error", std::to_string(worst_phase));
  RecordProperty("worst_mass_error", std::to_string(worst_mass));

  const PisarenkoSearchGrid grid(m);
  int valid = 0, fast = 0;
  std::vector<Complex> c(m + 1);
  PisarenkoEstimate estimate;
  for (int64_t p = 0; p < pixels; ++p) {
    if (!solved.valid(p)) continue;
    solved.moments(p, c);
    ++valid;
    fast += PisarenkoByLevinson(c, grid, &estimate);
  }
  RecordProperty("fast_route_pixels", absl::StrCat(fast, " of ", valid));
  EXPECT_GE(fast, 0.95 * valid) << "m = " << m;

  // The optimized kernel (b above) settles most pixels eight or four at a time in SIMD lanes for
  // m <= 8, the rest one by one; above 8 every pixel goes one by one. (Under the sanitizers the
  // lanes are compiled for m = 1, 3, 4 and 8 only: the orders this suite runs.)
  PisarenkoImage lanes = internal::AllocatePisarenko(solved);
  const int64_t decided = internal::PisarenkoBlock(solved, grid, 0, pixels, &lanes);
  RecordProperty("lane_pixels", absl::StrCat(decided, " of ", valid));
  if (m <= 8) {
    EXPECT_GE(decided, 0.9 * valid) << "m = " << m;
  } else {
    EXPECT_EQ(decided, 0) << "m = " << m;
  }
}

// The reference's and the optimized kernel's ranges and flags of one image.
struct Ranges {
  std::vector<float> expected, got;
  std::vector<uint8_t> expected_flags, got_flags;
};
Ranges RangesBothWays(const SolvedImage& solved, const RangeOptions& options) {
  const size_t pixels = static_cast<size_t>(solved.geometry.pixel_count());
  Ranges r{std::vector<float>(pixels), std::vector<float>(pixels), solved.flags, solved.flags};
  reference::MeseRange(solved, options, r.expected, r.expected_flags);
  optimized::MeseRange(solved, options, r.got, r.got_flags);
  return r;
}

// The range contract on every pixel: identical flags, no range where the reference has none,
// else within kRangeTolerance.
void ExpectRangesWithinContract(const Ranges& r, const std::string& context) {
  EXPECT_EQ(r.got_flags, r.expected_flags) << context;
  for (size_t p = 0; p < r.expected.size(); ++p) {
    if (std::isnan(r.expected[p])) {
      EXPECT_TRUE(std::isnan(r.got[p])) << "pixel " << p << ", " << context;
    } else {
      EXPECT_NEAR(r.got[p], r.expected[p], kRangeTolerance) << "pixel " << p << ", " << context;
    }
  }
}

TEST_P(Kernels, RangeWithinATenthOfAMillimetreWithIdenticalFlags) {
  const int m = GetParam();
  const SolvedImage solved = reference::Solve(RandomFrame(m, 400 + m), SolveOptions{});
  // Automatic grids (16 (m+1) phases, a multiple of 4: by orbits in the optimized kernel), one
  // that is a multiple of 4 but not of 8 (by orbits, 26 base phases), the coarsest by orbits (a
  // quarter of 7 bins), one that is not a multiple of 4
  // (by phases) and one coarse enough for the per-pixel path of the optimized kernel.
  const std::pair<double, int> cases[] = {{0.0, 0},   {0.1, 0},  {0.5, 0},   {1.0, 0},
                                          {0.1, 100}, {0.1, 28}, {0.1, 101}, {0.1, 20}};
  for (const auto& [threshold, bins] : cases) {
    RangeOptions options;
    options.threshold = threshold;
    options.search_bins = bins;
    ExpectRangesWithinContract(RangesBothWays(solved, options),
                               absl::StrCat("m = ", m, ", bins ", bins));
  }
}

TEST_P(Kernels, RangeOfASeriesThatOverflowsIsTheReferences) {
  // q_0 = q_1 = 1e154: the denominator's series has a_0 = 2e308, past the largest double, so the
  // optimized kernel's grid (from the series) is infinite or NaN, while the reference's (from
  // |p|^2, finite near phi = pi, where p vanishes) has a minimum there. Such a pixel must take
  // the reference's path and find its peak; a NaN pixel must stay without a return.
  const int m = GetParam();
  SolvedImage solved = reference::Solve(RandomFrame(m, 450 + m), SolveOptions{});
  const int64_t pixels = kGeometry.pixel_count();
  for (int j = 0; j <= m; ++j) {
    for (int64_t p : {int64_t{0}, int64_t{9}, pixels - 1}) {
      solved.q_real[j * pixels + p] = j <= 1 ? 1e154 : 0.0;
      solved.q_imag[j * pixels + p] = 0.0;
    }
    solved.q_real[j * pixels + 5] = std::numeric_limits<double>::quiet_NaN();
  }
  const Ranges r = RangesBothWays(solved, RangeOptions{});
  for (int64_t p : {int64_t{0}, int64_t{9}, pixels - 1}) {
    ASSERT_FALSE(std::isnan(r.expected[p])) << "the reference finds the peak at pi";
    EXPECT_EQ(r.got[p], r.expected[p]) << p;
  }
  EXPECT_TRUE(std::isnan(r.got[5]));
  ExpectRangesWithinContract(r, absl::StrCat("m = ", m));
}

TEST(RangeKernel, APixelWithMoreGridMinimaThanItsOrderIsTheReferencesInEveryBuild) {
  // A nearly flat series of order 1 (found by the review of the pixels-in-lanes kernel): its
  // grid, at rounding level, has more minima than a degree-1 series can. Such a pixel takes
  // the reference's path whatever order its lanes are padded to (1 in release builds, 4 under
  // the sanitizers); the padded slots once kept it on the vector path there, with a range
  // where the reference has none.
  SolvedImage solved = reference::Solve(RandomFrame(1, 460), SolveOptions{});
  const int64_t pixels = kGeometry.pixel_count();
  for (int64_t p : {int64_t{2}, int64_t{17}}) {
    solved.q_real[p] = 1.004;
    solved.q_imag[p] = 0.0;
    solved.q_real[pixels + p] = 4.94e-17;
    solved.q_imag[pixels + p] = -9.75e-17;
  }
  const Ranges r = RangesBothWays(solved, RangeOptions{});
  for (int64_t p : {int64_t{2}, int64_t{17}}) {
    EXPECT_EQ(r.got_flags[p], r.expected_flags[p]) << p;
    EXPECT_EQ(std::isnan(r.got[p]), std::isnan(r.expected[p])) << p;
    if (!std::isnan(r.expected[p])) {
      EXPECT_EQ(r.got[p], r.expected[p]) << p;
    }
  }
}

// Pixels of three returns whose first is the weakest (Range.AWeakEarlyReturnCountsByItsLight at
// many phases and weights): resolved less sharply than the later two, its peak is often below
// the threshold's height, and then counts only by its light where the density falls far enough
// on both sides before the neighbouring peaks. The optimized kernel decides that in its lanes,
// from the crests of each grid; the reference scans the grid between the peaks.
TEST(RangeKernel, APeakThatMayPassByItsLightIsDecidedAsTheReferenceDoes) {
  for (const int m : {3, 4, 8}) {
    std::mt19937_64 rng(700 + m);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    MomentImage image(kGeometry, m);
    const int64_t pixels = kGeometry.pixel_count();
    image.valid.assign(pixels, 1);
    std::vector<testing::SparseMeasure> truths(pixels);
    for (int64_t p = 0; p < pixels; ++p) {
      testing::SparseMeasure& truth = truths[p];
      const double first = 0.3 + 1.5 * unit(rng);
      const double second = first + 0.2 + 0.8 * unit(rng);
      truth.phase = {first, second, second + 0.4 + (kTwoPi - 0.7 - second) * unit(rng)};
      truth.weight = {0.05 + 0.6 * unit(rng), 1.0, 0.5 + 0.5 * unit(rng)};
      const std::vector<Complex> c = truth.Moments(m);
      for (int j = 0; j <= m; ++j) {
        image.real_plane(j)[p] = static_cast<float>(c[j].real());
        image.imag_plane(j)[p] = static_cast<float>(c[j].imag());
      }
    }
    const SolvedImage solved = reference::Solve(image, SolveOptions{});
    for (const double threshold : {0.1, 0.3}) {
      RangeOptions options;
      options.threshold = threshold;
      const Ranges r = RangesBothWays(solved, options);
      ExpectRangesWithinContract(r, absl::StrCat("m = ", m, ", threshold ", threshold));
      // The frame must hold both outcomes: first returns below the threshold's height (passed
      // by their light), and first returns of at least the threshold's share of the light
      // that did not pass (the reference's first return is the second).
      const std::vector<double> grid = UniformPhases(4096);
      std::vector<Complex> q(m + 1);
      std::vector<double> density(grid.size());
      int by_light = 0, refused = 0;
      for (int64_t p = 0; p < pixels; ++p) {
        if (std::isnan(r.expected[p])) continue;
        solved.coefficients(p, q);
        MeseDensity(q, grid, density);
        const double highest = *std::max_element(density.begin(), density.end());
        const double phase = RangeToPhase(r.expected[p], options.base_frequency_hz);
        by_light += MeseDensity(q, phase) < threshold * highest;
        refused += truths[p].weight[0] >= threshold && std::abs(phase - truths[p].phase[1]) < 0.1;
      }
      RecordProperty(absl::StrCat("m", m, "_threshold_", threshold),
                     absl::StrCat(by_light, " by light, ", refused, " refused"));
      EXPECT_GE(by_light, pixels / 50) << "m = " << m << ", threshold " << threshold;
      // (At m = 8 the first return is resolved as a peak of its own nearly always.)
      if (m <= 4) {
        EXPECT_GE(refused, pixels / 50) << "m = " << m << ", threshold " << threshold;
      }
    }
  }
}

TEST_P(Kernels, ResultsDoNotDependOnTheThreadCount) {
  const int m = GetParam();
  const MomentImage image = RandomFrame(m, 500 + m);
  const auto phases = UniformPhases(64);
  std::vector<std::vector<float>> density(2);
  std::vector<std::vector<float>> range(2);
  for (int threads : {1, 2}) {
    SetKernelOptions({.kind = KernelKind::kOptimized, .threads = threads});
    const SolvedImage solved = Solve(image, SolveOptions{});
    density[threads - 1].resize(phases.size() * kGeometry.pixel_count());
    DensitySlices(solved, phases, density[threads - 1]);
    range[threads - 1].resize(kGeometry.pixel_count());
    std::vector<uint8_t> flags = solved.flags;
    MeseRange(solved, RangeOptions{}, range[threads - 1], flags);
  }
  for (size_t i = 0; i < density[0].size(); ++i) {
    EXPECT_TRUE(density[0][i] == density[1][i] ||
                (std::isnan(density[0][i]) && std::isnan(density[1][i])));
  }
  for (size_t i = 0; i < range[0].size(); ++i) {
    EXPECT_TRUE(range[0][i] == range[1][i] || (std::isnan(range[0][i]) && std::isnan(range[1][i])));
  }
}

INSTANTIATE_TEST_SUITE_P(Orders, Kernels, ::testing::Values(1, 3, 4, 8, 10, 16),
                         [](const ::testing::TestParamInfo<int>& info) {
                           return absl::StrCat("m", info.param);
                         });

TEST(KernelSelection, TheImageApiRunsTheChosenKind) {
  const MomentImage image = RandomFrame(3, 600);
  const auto phases = UniformPhases(32);
  const int64_t pixels = kGeometry.pixel_count();
  const SolvedImage solved = reference::Solve(image, SolveOptions{});
  std::vector<float> reference_out(phases.size() * pixels), optimized_out(reference_out.size()),
      api_out(reference_out.size());
  reference::DensitySlices(solved, phases, reference_out);
  optimized::DensitySlices(solved, phases, optimized_out);
  ASSERT_NE(reference_out, optimized_out) << "the two kinds must be distinguishable here";
  SetKernelOptions({.kind = KernelKind::kReference});
  DensitySlices(solved, phases, api_out);
  EXPECT_EQ(api_out.size(), reference_out.size());
  for (size_t i = 0; i < api_out.size(); ++i) {
    EXPECT_TRUE(api_out[i] == reference_out[i] ||
                (std::isnan(api_out[i]) && std::isnan(reference_out[i])));
  }
  SetKernelOptions({});
  EXPECT_EQ(GetKernelOptions().kind, KernelKind::kOptimized);
}

// TRANSIENT_SIMD caps the vector kernels' instruction set (the release tests run the contract
// above with each); what it cannot follow leaves the CPU's and says why.
TEST(SimdLevel, TransientSimdCapsTheLevelAndReportsWhatItCannotFollow) {
  using simd::Level;
  std::string message = "stale";
  EXPECT_EQ(simd::CappedLevel(nullptr, Level::kX86_64_V4, &message), Level::kX86_64_V4);
  EXPECT_EQ(message, "");
  EXPECT_EQ(simd::CappedLevel("baseline", Level::kX86_64_V4, &message), Level::kBaseline);
  EXPECT_EQ(message, "");
  EXPECT_EQ(simd::CappedLevel("x86-64-v3", Level::kX86_64_V4, &message), Level::kX86_64_V3);
  EXPECT_EQ(simd::CappedLevel("x86-64-v3", Level::kX86_64_V3, &message), Level::kX86_64_V3);
  EXPECT_EQ(message, "");
  // Above the CPU: its own level, and why.
  EXPECT_EQ(simd::CappedLevel("x86-64-v4", Level::kX86_64_V3, &message), Level::kX86_64_V3);
  EXPECT_EQ(message,
            "TRANSIENT_SIMD=x86-64-v4: this CPU runs x86-64-v3 at best; the vector kernels run "
            "x86-64-v3");
  // Not a level's name: the CPU's, and the names expected.
  for (const char* bad : {"", "avx2", "Baseline", "x86-64-v3 "}) {
    EXPECT_EQ(simd::CappedLevel(bad, Level::kX86_64_V3, &message), Level::kX86_64_V3) << bad;
    EXPECT_THAT(message, ::testing::HasSubstr("expected x86-64-v4, x86-64-v3 or baseline")) << bad;
  }
}

// The level the kernels run is the one TRANSIENT_SIMD allows on this CPU (in the release tests'
// runs with TRANSIENT_SIMD=baseline, the baseline).
TEST(SimdLevel, TheKernelsRunTheLevelTheEnvironmentAllows) {
  std::string message;
  const simd::Level expected =
      simd::CappedLevel(std::getenv("TRANSIENT_SIMD"), simd::DetectedLevel(), &message);
  EXPECT_EQ(simd::CpuLevel(), expected) << simd::LevelName(expected);
  std::cerr << "vector kernels: " << simd::LevelName(simd::CpuLevel()) << "\n";
}

}  // namespace
}  // namespace transient
