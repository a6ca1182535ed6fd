#include "transient/reconstruct/phase_unwrapping.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <random>
#include <vector>

#include "tests/support/status_matchers.h"
#include "transient/reconstruct/kernels.h"
#include "transient/reconstruct/moments.h"
#include "transient/reconstruct/physical_constants.h"

namespace transient {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;
using ComplexF = std::complex<float>;

// The Kinect v2's frequencies: harmonics 10, 2, 15 of 8 MHz (research/libusb.md §1.5).
UnwrapOptions Kinect() { return {.base_frequency_hz = 8e6, .harmonics = {10, 2, 15}}; }

// Calibrated moments of returns (range, weight) at harmonics j.
std::vector<ComplexF> Moments(const UnwrapOptions& o,
                              std::vector<std::pair<double, double>> returns) {
  std::vector<ComplexF> c;
  for (int j : o.harmonics) {
    std::complex<double> sum = 0.0;
    for (auto [range, weight] : returns) {
      sum += std::polar(weight, j * RangeToPhase(range, o.base_frequency_hz));
    }
    c.emplace_back(static_cast<float>(sum.real()), static_cast<float>(sum.imag()));
  }
  return c;
}

TEST(UnwrapPixel, ASingleReturnAnywhereInTheUnambiguousRangeIsFoundExactly) {
  const UnwrapOptions o = Kinect();
  const double unambiguous = UnambiguousRange(o.base_frequency_hz);  // 18.74 m
  EXPECT_NEAR(unambiguous, 18.737, 1e-3);
  for (double range = 0.05; range < unambiguous; range += 0.173) {
    const UnwrappedPixel u = UnwrapPixel(Moments(o, {{range, 2.0}}), o);
    EXPECT_EQ(u.flags, 0) << range;
    EXPECT_NEAR(u.range_m, range, 2e-5) << range;  // float moments
    EXPECT_NEAR(u.amplitude, 2.0, 1e-6);
    EXPECT_NEAR(u.confidence, 1.0, 1e-6);
  }
}

TEST(UnwrapPixel, NoisyPhasesUnwrapToTheRightCandidateAndMultipathLowersConfidence) {
  const UnwrapOptions o = Kinect();
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 0.05);  // 5 % of the amplitude per component
  int wrong = 0, flagged = 0;
  double max_error = 0.0;
  for (int trial = 0; trial < 2000; ++trial) {
    const double range = 0.5 + 17.0 * (trial + 0.5) / 2000.0;
    std::vector<ComplexF> c = Moments(o, {{range, 1.0}});
    for (ComplexF& z : c) {
      z += ComplexF(static_cast<float>(noise(rng)), static_cast<float>(noise(rng)));
    }
    const UnwrappedPixel u = UnwrapPixel(c, o);
    if (u.flags != 0) {
      ++flagged;
      continue;
    }
    const double error = std::abs(u.range_m - range);
    if (error > 0.3) ++wrong;
    else max_error = std::max(max_error, error);
  }
  EXPECT_EQ(wrong, 0);
  EXPECT_LT(flagged, 20);
  EXPECT_LT(max_error, 0.05);  // a few cm at 5 % noise: the 120 MHz phase dominates
  // A second return (multipath) lowers the coherence of the frequencies (1 - 0.97 here).
  const UnwrappedPixel clean = UnwrapPixel(Moments(o, {{3.0, 1.0}}), o);
  const UnwrappedPixel mixed = UnwrapPixel(Moments(o, {{3.0, 1.0}, {3.9, 0.5}}), o);
  EXPECT_NEAR(clean.confidence, 1.0, 1e-6);
  EXPECT_LT(mixed.confidence, 0.99);
}

TEST(UnwrapPixel, PhasesThatFitTwoDistancesEquallyAreFlaggedAmbiguous) {
  const UnwrapOptions o = Kinect();
  // Without the 16 MHz phase, 80 and 120 MHz repeat every 18.74 m / 5 = 3.75 m: ranges 1 m and
  // 4.75 m have the same phases at both.
  std::vector<ComplexF> c = Moments(o, {{1.0, 1.0}});
  c[1] = 0.0f;  // no light at 16 MHz
  const UnwrappedPixel u = UnwrapPixel(c, o);
  EXPECT_EQ(u.flags, kFlagAmbiguous);
  EXPECT_TRUE(std::isnan(u.range_m));
  EXPECT_NEAR(u.confidence, 1.0, 1e-5);  // the lit frequencies agree: it is their number that fails
}

TEST(UnwrapPixel, TooLittleLightIsFlaggedLowAmplitude) {
  UnwrapOptions o = Kinect();
  o.min_amplitude = 0.5;
  UnwrappedPixel u = UnwrapPixel(Moments(o, {{2.0, 0.4}}), o);
  EXPECT_EQ(u.flags, kFlagLowAmplitude);
  EXPECT_TRUE(std::isnan(u.range_m));
  EXPECT_NEAR(u.amplitude, 0.4, 1e-6);
  u = UnwrapPixel(Moments(o, {{2.0, 0.0}}), Kinect());  // no light at all, no threshold
  EXPECT_EQ(u.flags, kFlagLowAmplitude);
}

TEST(UnwrapImage, KeepsTheMomentFlagsMarksInvalidPixelsAndChecksTheOrder) {
  const UnwrapOptions o = Kinect();
  MomentImage m(ImageGeometry{3, 1}, 15);
  m.valid = {1, 0, 1};
  m.flags = {kFlagOutlierFilled, 0, 0};
  for (int p : {0, 2}) {
    const std::vector<ComplexF> c = Moments(o, {{2.5 * (p + 1), 1.0}});
    for (size_t i = 0; i < c.size(); ++i) {
      m.real_plane(o.harmonics[i])[p] = c[i].real();
      m.imag_plane(o.harmonics[i])[p] = c[i].imag();
    }
  }
  m.real_plane(2)[2] = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> range, amplitude, confidence;
  std::vector<uint8_t> flags;
  ASSERT_THAT(UnwrapImage(m, o, &range, &amplitude, &confidence, &flags), IsOk());
  EXPECT_NEAR(range[0], 2.5, 1e-4);
  EXPECT_EQ(flags[0], kFlagOutlierFilled);
  EXPECT_TRUE(std::isnan(range[1]));
  EXPECT_EQ(flags[1], kFlagInvalidInput);
  EXPECT_TRUE(std::isnan(range[2]));  // a NaN moment: invalid, never a number
  EXPECT_EQ(flags[2], kFlagInvalidInput);

  MomentImage low(ImageGeometry{3, 1}, 10);
  EXPECT_THAT(UnwrapImage(low, o, &range, &amplitude, &confidence, &flags),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("order m = 10. Violated constraint: m >= 15")));
}

// The image loop takes eight or four pixels at a time in the optimized kernels
// (optimized_unwrap.cc): its results must be UnwrapPixel's bit for bit, for every kind of pixel in
// any lane: single and mixed returns, noise that makes some ambiguous, too little light, no light,
// NaN moments, invalid pixels; for the Kinect's harmonics, for 1, 2, 3 (Newton's steps then reach
// the library's rotation) and for one harmonic alone.
TEST(UnwrapImage, TheOptimizedLoopEqualsUnwrapPixelBitForBit) {
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.03);
  for (const UnwrapOptions& base :
       {Kinect(), UnwrapOptions{.base_frequency_hz = 20e6, .harmonics = {1, 2, 3}},
        UnwrapOptions{.base_frequency_hz = 20e6, .harmonics = {1}}}) {
    UnwrapOptions o = base;
    o.min_amplitude = 0.05;
    const double unambiguous_m = kSpeedOfLight / (2.0 * o.base_frequency_hz);
    const ImageGeometry geometry{37, 23};  // not a multiple of the eight or four lanes
    const int order = *std::max_element(o.harmonics.begin(), o.harmonics.end());
    MomentImage m(geometry, order);
    m.valid.assign(geometry.pixel_count(), 1);
    for (int64_t p = 0; p < geometry.pixel_count(); ++p) {
      std::vector<std::pair<double, double>> returns = {{uniform(rng) * unambiguous_m, 1.0}};
      if (p % 3 == 0) returns.push_back({uniform(rng) * unambiguous_m, uniform(rng)});
      if (p % 11 == 0) returns = {{1.0, 0.01}};  // below min_amplitude
      std::vector<ComplexF> c = Moments(o, returns);
      for (size_t i = 0; i < c.size(); ++i) {
        c[i] += ComplexF(static_cast<float>(noise(rng)), static_cast<float>(noise(rng)));
        if (p % 13 == 0) c[i] = 0.0f;  // no light
        m.real_plane(o.harmonics[i])[p] = c[i].real();
        m.imag_plane(o.harmonics[i])[p] = c[i].imag();
      }
      if (p % 17 == 0) m.real_plane(o.harmonics[0])[p] = std::nanf("");
      if (p % 19 == 0) m.valid[p] = 0;
    }
    std::vector<float> range[2], amplitude[2], confidence[2];
    std::vector<uint8_t> flags[2];
    for (int kind = 0; kind < 2; ++kind) {
      SetKernelOptions({.kind = kind == 0 ? KernelKind::kReference : KernelKind::kOptimized});
      ASSERT_THAT(
          UnwrapImage(m, o, &range[kind], &amplitude[kind], &confidence[kind], &flags[kind]),
          IsOk());
    }
    SetKernelOptions({});
    int ranged = 0, ambiguous = 0;
    auto same = [](float a, float b) { return a == b || (std::isnan(a) && std::isnan(b)); };
    for (int64_t p = 0; p < geometry.pixel_count(); ++p) {
      EXPECT_EQ(flags[1][p], flags[0][p]) << "pixel " << p;
      EXPECT_TRUE(same(range[1][p], range[0][p]))
          << "pixel " << p << ": " << range[1][p] << " against " << range[0][p];
      EXPECT_TRUE(same(amplitude[1][p], amplitude[0][p])) << "pixel " << p;
      EXPECT_TRUE(same(confidence[1][p], confidence[0][p])) << "pixel " << p;
      ranged += !std::isnan(range[0][p]);
      ambiguous += (flags[0][p] & kFlagAmbiguous) != 0;
    }
    if (o.harmonics.size() > 1) {
      EXPECT_GT(ranged, geometry.pixel_count() / 2) << "most pixels should get a range";
      EXPECT_GT(ambiguous, 0) << "the frame should have ambiguous pixels";
    }
  }
}

TEST(UnwrapOptions, ValidateNamesFieldValueAndRule) {
  EXPECT_THAT(Kinect().Validate(), IsOk());
  UnwrapOptions o = Kinect();
  o.harmonics = {};
  EXPECT_THAT(o.Validate(), StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("harmonics")));
  o = Kinect();
  o.harmonics = {2, 17};
  EXPECT_THAT(o.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                     HasSubstr("harmonics = 2,17. Violated constraint: each in")));
  o = Kinect();
  o.harmonics = {2, 4};  // every distance would have a twin half the range away
  EXPECT_THAT(o.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                     HasSubstr("harmonics = 2,4. Violated constraint: no "
                                               "common factor (2)")));
  o = Kinect();
  o.base_frequency_hz = 0.0;
  EXPECT_THAT(o.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                     HasSubstr("base_frequency_hz = 0")));
  o = Kinect();
  o.min_amplitude = -1.0;
  EXPECT_THAT(o.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("min_amplitude = -1")));
  o = Kinect();
  o.ambiguity_margin = 3.0;
  EXPECT_THAT(o.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("ambiguity_margin = 3")));
}

}  // namespace
}  // namespace transient
