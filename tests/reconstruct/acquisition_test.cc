#include "transient/reconstruct/acquisition.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <set>

#include "tests/support/status_matchers.h"

namespace transient {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::IsOkAndHolds;
using ::transient::testing::StatusIs;

constexpr double kExact = 1e-14;  // a few ulps of sums of n_phi <= 64 terms of order 1

AcquisitionSchedule MakeSchedule(const ScheduleOptions& options) {
  absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(options);
  EXPECT_THAT(schedule.status(), IsOk());
  return *std::move(schedule);
}

TEST(AcquisitionSchedule, FourBucketEstimatedOneTakeCostsTwelveRawFrames) {
  ScheduleOptions options;  // thesis §8.5.3: m = 3, four-bucket, c_0 estimated, one take
  options.order = 3;
  options.sampling = SamplingScheme::kFourBucket;
  options.zeroth = ZerothScheme::kEstimated;
  const AcquisitionSchedule schedule = MakeSchedule(options);
  EXPECT_EQ(schedule.raw_frames_per_frame(), 12);
  EXPECT_EQ(schedule.exposures_per_take(), 12);
  EXPECT_FALSE(schedule.zeroth_measured());
  // Harmonics 1..3 in order, buckets 0, pi/2, pi, 3pi/2 each, at j*f.
  for (int i = 0; i < 12; ++i) {
    const ExposureConfig& e = schedule.exposures()[i];
    EXPECT_EQ(e.harmonic, 1 + i / 4);
    EXPECT_DOUBLE_EQ(e.frequency_hz, e.harmonic * options.base_frequency_hz);
    EXPECT_DOUBLE_EQ(e.phase_shift_rad, (i % 4) * 0.5 * std::numbers::pi);
    EXPECT_TRUE(e.illumination);
    EXPECT_EQ(e.take, 0);
    EXPECT_DOUBLE_EQ(e.exposure_s, options.exposure_s);
  }
}

TEST(AcquisitionSchedule, ZerothSchemesAddTheirExposuresAndTakesMultiply) {
  ScheduleOptions options;
  options.order = 3;
  options.zeroth = ZerothScheme::kUnmodulatedPair;
  AcquisitionSchedule pair = MakeSchedule(options);
  EXPECT_EQ(pair.raw_frames_per_frame(), 14);
  EXPECT_EQ(pair.exposures()[0].frequency_hz, 0.0);
  EXPECT_TRUE(pair.exposures()[0].illumination);
  EXPECT_FALSE(pair.exposures()[1].illumination);
  EXPECT_EQ(pair.exposures()[1].harmonic, 0);

  options.zeroth = ZerothScheme::kLowFrequencyProxy;
  AcquisitionSchedule proxy = MakeSchedule(options);
  EXPECT_EQ(proxy.raw_frames_per_frame(), 16);
  for (int b = 0; b < 4; ++b) {
    EXPECT_EQ(proxy.exposures()[b].harmonic, 0);
    EXPECT_DOUBLE_EQ(proxy.exposures()[b].frequency_hz, options.proxy_frequency_hz);
    EXPECT_DOUBLE_EQ(proxy.exposures()[b].phase_shift_rad, b * 0.5 * std::numbers::pi);
  }

  options.takes = 5;
  AcquisitionSchedule takes = MakeSchedule(options);
  EXPECT_EQ(takes.raw_frames_per_frame(), 5 * 16);
  EXPECT_EQ(takes.exposures_per_take(), 16);
  for (int i = 0; i < takes.raw_frames_per_frame(); ++i) {
    EXPECT_EQ(takes.exposures()[i].take, i / 16);
  }
}

TEST(AcquisitionSchedule, ArccosSubExposuresHaveEqualWeightsAtArccosPhases) {
  for (int n : {1, 2, 8, 64}) {
    ScheduleOptions options;
    options.sampling = SamplingScheme::kArccos;
    options.phase_steps = n;
    const AcquisitionSchedule schedule = MakeSchedule(options);
    ASSERT_EQ(schedule.sub_exposures().size(), static_cast<size_t>(n));
    double total = 0.0, mean_cos = 0.0, mean_sin = 0.0;
    for (int k = 0; k < n; ++k) {
      const SubExposure& s = schedule.sub_exposures()[k];
      EXPECT_NEAR(s.phase_shift_rad, std::acos(1.0 - (2.0 * k + 1.0) / n), kExact);  // eq. 8.7
      EXPECT_DOUBLE_EQ(s.weight, 1.0 / n);
      total += s.weight;
      mean_cos += s.weight * std::cos(s.phase_shift_rad);
      mean_sin += s.weight * std::sin(s.phase_shift_rad);
    }
    EXPECT_NEAR(total, 1.0, kExact);
    EXPECT_NEAR(mean_cos, 0.0, kExact) << "n_phi = " << n;
    // sum_k (1 - (2k+1)/n) = 0: the gain is purely imaginary, -i * mean sin(theta_k).
    const Complex g = schedule.nominal_gain();
    EXPECT_NEAR(g.real(), 0.0, kExact) << "n_phi = " << n;
    EXPECT_NEAR(g.imag(), -mean_sin, kExact);
    EXPECT_LT(g.imag(), 0.0);
  }
}

TEST(AcquisitionSchedule, ArccosGainApproachesPiOverFour) {
  // Prop. 8.3: the sinusoidal component is reduced by pi/4 in the limit n_phi -> infinity. The
  // midpoint rule of int_0^1 sqrt(1 - (1-2k)^2) dk converges like n^(-3/2) (square-root ends).
  ScheduleOptions options;
  options.phase_steps = 64;
  const double gain = std::abs(MakeSchedule(options).nominal_gain());
  constexpr double kMidpointError = 1e-3;  // the sum is 4.7e-4 below pi/4 (computed offline)
  EXPECT_NEAR(gain, std::numbers::pi / 4.0, kMidpointError);
  options.phase_steps = 1;  // one sub-exposure at arccos(0) = pi/2: g = -i exactly
  const Complex g1 = MakeSchedule(options).nominal_gain();
  EXPECT_NEAR(g1.real(), 0.0, kExact);
  EXPECT_NEAR(g1.imag(), -1.0, kExact);
}

TEST(AcquisitionSchedule, HarmonicCancellationWeightsFollowTheSineWindow) {
  const int n = 3;
  ScheduleOptions options;
  options.sampling = SamplingScheme::kHarmonicCancellation;
  options.phase_steps = n;
  const AcquisitionSchedule schedule = MakeSchedule(options);
  ASSERT_EQ(schedule.sub_exposures().size(), 3u);
  // sin(pi/4), sin(pi/2), sin(3pi/4) normalised: 1/(2+sqrt2)*(sqrt2/2, 1, sqrt2/2)...
  const double total = std::sqrt(2.0) + 1.0;
  Complex expected_gain{0.0, 0.0};
  for (int k = 0; k < n; ++k) {
    const SubExposure& s = schedule.sub_exposures()[k];
    const double w = std::sin((k + 1) * std::numbers::pi / 4.0) / total;
    EXPECT_NEAR(s.weight, w, kExact);
    EXPECT_NEAR(s.phase_shift_rad, k * std::numbers::pi / 4.0, kExact);
    expected_gain += w * std::polar(1.0, -k * std::numbers::pi / 4.0);
  }
  EXPECT_NEAR(std::abs(schedule.nominal_gain() - expected_gain), 0.0, kExact);
  // Symmetric window around pi/4: the gain has phase -pi/4.
  EXPECT_NEAR(std::arg(schedule.nominal_gain()), -std::numbers::pi / 4.0, kExact);
}

TEST(AcquisitionSchedule, FourBucketIgnoresPhaseStepsAndHasUnitGain) {
  ScheduleOptions options;
  options.sampling = SamplingScheme::kFourBucket;
  options.phase_steps = 8;
  const AcquisitionSchedule schedule = MakeSchedule(options);
  EXPECT_EQ(schedule.options().phase_steps, 1);
  ASSERT_EQ(schedule.sub_exposures().size(), 1u);
  EXPECT_EQ(schedule.nominal_gain(), Complex(1.0, 0.0));
}

TEST(AcquisitionSchedule, IndexOfFindsEveryExposureAndIgnoresCycleAndSequence) {
  ScheduleOptions options;
  options.zeroth = ZerothScheme::kUnmodulatedPair;
  options.takes = 3;
  const AcquisitionSchedule schedule = MakeSchedule(options);
  std::set<int> seen;
  for (int i = 0; i < schedule.raw_frames_per_frame(); ++i) {
    ExposureConfig config = schedule.exposures()[i];
    config.cycle = 17;
    config.sequence = 1234 + i;
    config.timestamp_s = 0.5;
    absl::StatusOr<int> index = schedule.IndexOf(config);
    ASSERT_THAT(index.status(), IsOk());
    EXPECT_EQ(*index, i);
    seen.insert(*index);
  }
  EXPECT_EQ(seen.size(), static_cast<size_t>(schedule.raw_frames_per_frame()));
}

TEST(AcquisitionSchedule, IndexOfRefusesForeignExposures) {
  ScheduleOptions options;
  options.order = 2;
  options.takes = 2;
  const AcquisitionSchedule schedule = MakeSchedule(options);
  ExposureConfig config = schedule.exposures()[4];
  config.sequence = 99;
  ExposureConfig wrong_take = config;
  wrong_take.take = 2;
  EXPECT_THAT(schedule.IndexOf(wrong_take).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("frame 99 (")));
  ExposureConfig wrong_harmonic = config;
  wrong_harmonic.harmonic = 3;
  wrong_harmonic.frequency_hz = 3 * options.base_frequency_hz;
  EXPECT_THAT(schedule.IndexOf(wrong_harmonic).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("harmonic 3")));
  ExposureConfig wrong_shift = config;
  wrong_shift.phase_shift_rad = 0.25 * std::numbers::pi;
  EXPECT_THAT(schedule.IndexOf(wrong_shift).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("not an exposure")));
  ExposureConfig wrong_frequency = config;
  wrong_frequency.frequency_hz *= 1.01;
  EXPECT_FALSE(schedule.IndexOf(wrong_frequency).ok());
  ExposureConfig wrong_exposure = config;
  wrong_exposure.exposure_s *= 2.0;
  EXPECT_FALSE(schedule.IndexOf(wrong_exposure).ok());
  ExposureConfig dark = config;
  dark.illumination = false;
  EXPECT_FALSE(schedule.IndexOf(dark).ok());
}

TEST(ScheduleOptions, ValidateNamesFieldValueAndRule) {
  const auto check = [](ScheduleOptions options, absl::string_view text) {
    EXPECT_THAT(options.Validate(), StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(text)));
    EXPECT_THAT(AcquisitionSchedule::Create(options).status(),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(text)));
  };
  EXPECT_THAT(ScheduleOptions().Validate(), IsOk());
  ScheduleOptions o;
  o.order = 0;
  check(o, "order = 0. Violated constraint: 1 <= order <= 16");
  o = ScheduleOptions();
  o.order = kMaxOrder + 1;
  check(o, "order = 17");
  o = ScheduleOptions();
  o.base_frequency_hz = -1.0;
  check(o, "base_frequency_hz = -1");
  o = ScheduleOptions();
  o.phase_steps = 65;
  check(o, "phase_steps = 65");
  o = ScheduleOptions();
  o.zeroth = ZerothScheme::kLowFrequencyProxy;
  o.proxy_frequency_hz = 30e6;
  check(o, "proxy_frequency_hz = 3e+07");
  o = ScheduleOptions();
  o.exposure_s = 0.0;
  check(o, "exposure_s = 0");
  o = ScheduleOptions();
  o.takes = 0;
  check(o, "takes = 0. Violated constraint: 1 <= takes <= 1024");
  o = ScheduleOptions();
  o.buckets = 2;
  check(o, "buckets = 2. Violated constraint: 3 <= buckets <= 16");
  o = ScheduleOptions();
  o.harmonics = {10, 2, 15};
  check(o, "order = 3. Violated constraint: order = max(harmonics) = 15 (harmonics 10,2,15)");
  o.order = 2;
  o.harmonics = {2, 0};
  check(o, "harmonics = 2,0. Violated constraint: every harmonic in 1..16 (found 0)");
  o.order = 2;
  o.harmonics = {2, 2};
  check(o, "harmonics = 2,2. Violated constraint: distinct harmonics (2 twice)");
  o.order = 4;
  o.harmonics = {2, 4};
  check(o, "harmonics = 2,4. Violated constraint: no common factor (2): describe them as "
           "harmonics of 2 * base_frequency_hz");
}

// The Kinect v2's schedule (research/libusb.md §1.5): harmonics 10, 2, 15 of 8 MHz in that
// capture order, three phase steps of 120 degrees, no zeroth-moment exposure: 9 raw frames.
TEST(AcquisitionSchedule, AHarmonicSetWithThreeStepsListsItsExposuresInCaptureOrder) {
  ScheduleOptions o;
  o.base_frequency_hz = 8e6;
  o.order = 15;
  o.harmonics = {10, 2, 15};
  o.buckets = 3;
  o.sampling = SamplingScheme::kFourBucket;
  o.zeroth = ZerothScheme::kEstimated;
  absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(o);
  ASSERT_THAT(schedule.status(), IsOk());
  ASSERT_EQ(schedule->raw_frames_per_frame(), 9);
  const int want_harmonic[] = {10, 10, 10, 2, 2, 2, 15, 15, 15};
  for (int i = 0; i < 9; ++i) {
    const ExposureConfig& e = schedule->exposures()[static_cast<size_t>(i)];
    EXPECT_EQ(e.harmonic, want_harmonic[i]);
    EXPECT_DOUBLE_EQ(e.frequency_hz, want_harmonic[i] * 8e6);
    EXPECT_NEAR(e.phase_shift_rad, 2.0 * std::numbers::pi * (i % 3) / 3.0, 1e-15);
  }
  EXPECT_EQ(schedule->options().MeasuredHarmonics(), (std::vector<int>{10, 2, 15}));
  EXPECT_FALSE(schedule->options().HasAllHarmonics());
  EXPECT_EQ(schedule->options().MissingHarmonicsText("MESE"),
            "the schedule measures harmonics 2, 10, 15 of 8 MHz; MESE needs every harmonic "
            "1..15 (missing 1, 3-9, 11-14)");
  EXPECT_EQ(schedule->Describe(),
            "f = 8 MHz, harmonics 10, 2, 15, 3-step, zeroth: estimated, 1 take: 9 raw frames");
  // A set that is 1..m after all can be reconstructed.
  o.order = 3;
  o.harmonics = {3, 1, 2};
  EXPECT_TRUE(o.HasAllHarmonics());
  EXPECT_EQ(o.MissingHarmonicsText("MESE"), "");
  EXPECT_TRUE(ScheduleOptions().HasAllHarmonics());
  EXPECT_EQ(ScheduleOptions().MeasuredHarmonics(), (std::vector<int>{1, 2, 3}));
}

TEST(AcquisitionSchedule, BucketIndexInvertsBucketPhaseShiftModuloN) {
  for (int n = kMinPhaseBuckets; n <= kMaxPhaseBuckets; ++n) {
    for (int k = 0; k < n; ++k) {
      EXPECT_EQ(BucketIndex(BucketPhaseShift(k, n), n), k);
      // -2*pi*k/3 etc.
      EXPECT_EQ(BucketIndex(BucketPhaseShift(k, n) - 2.0 * std::numbers::pi, n), k);
    }
  }
}

TEST(HarmonicList, RoundTripsAndNamesTheBadEntry) {
  EXPECT_EQ(FormatHarmonicList(std::vector<int>{10, 2, 15}), "10,2,15");
  EXPECT_THAT(ParseHarmonicList("10,2,15"), IsOkAndHolds(std::vector<int>{10, 2, 15}));
  EXPECT_THAT(ParseHarmonicList("10,x,15").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("'x' is not an integer")));
  EXPECT_THAT(ParseHarmonicList("").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("is not an integer")));
}

TEST(AcquisitionSchedule, SchemeNamesRoundTrip) {
  for (SamplingScheme s : {SamplingScheme::kFourBucket, SamplingScheme::kArccos,
                           SamplingScheme::kHarmonicCancellation}) {
    absl::StatusOr<SamplingScheme> parsed = ParseSamplingScheme(SamplingSchemeName(s));
    ASSERT_THAT(parsed.status(), IsOk());
    EXPECT_EQ(*parsed, s);
  }
  for (ZerothScheme s : {ZerothScheme::kUnmodulatedPair, ZerothScheme::kLowFrequencyProxy,
                         ZerothScheme::kEstimated}) {
    absl::StatusOr<ZerothScheme> parsed = ParseZerothScheme(ZerothSchemeName(s));
    ASSERT_THAT(parsed.status(), IsOk());
    EXPECT_EQ(*parsed, s);
  }
  EXPECT_EQ(SamplingSchemeName(SamplingScheme::kArccos), "arccos");
  EXPECT_EQ(ZerothSchemeName(ZerothScheme::kLowFrequencyProxy), "proxy");
  EXPECT_THAT(ParseSamplingScheme("sine").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("'sine'")));
  EXPECT_THAT(ParseZerothScheme("measured").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("pair, proxy or estimated")));
}

TEST(AcquisitionSchedule, DescribeSummarisesTheSchedule) {
  ScheduleOptions options;  // defaults: 23 MHz, m = 3, arccos n_phi = 8, pair, 1 take
  EXPECT_EQ(MakeSchedule(options).Describe(),
            "f = 23 MHz, m = 3, arccos (n_phi = 8), zeroth: pair, 1 take: 14 raw frames");
  ExposureConfig e = MakeSchedule(options).exposures()[6];
  EXPECT_EQ(DescribeExposure(e),
            "harmonic 2 (46 MHz), phase shift 0.0000 rad, exposure 1.92 ms, illumination on, "
            "take 0");
}

// A depth camera (an OpenNI2 device): Z, then amplitude, per cycle; 8 m at most.
ScheduleOptions DepthCamera(bool amplitude) {
  ScheduleOptions options;
  options.sampling = SamplingScheme::kDepth;
  options.max_depth_m = 8.0;
  options.depth_amplitude = amplitude;
  return options;
}

TEST(DepthSchedule, HasADepthFrameAndOptionallyAnAmplitudeFrame) {
  const AcquisitionSchedule depth_only = MakeSchedule(DepthCamera(false));
  ASSERT_EQ(depth_only.raw_frames_per_frame(), 1);
  EXPECT_EQ(depth_only.exposures()[0].content, FrameContent::kDepth);
  const AcquisitionSchedule both = MakeSchedule(DepthCamera(true));
  ASSERT_EQ(both.raw_frames_per_frame(), 2);
  EXPECT_EQ(both.exposures_per_take(), 2);
  EXPECT_EQ(both.exposures()[0].content, FrameContent::kDepth);
  EXPECT_EQ(both.exposures()[1].content, FrameContent::kAmplitude);
  for (const ExposureConfig& e : both.exposures()) {
    EXPECT_EQ(e.harmonic, 0);
    EXPECT_EQ(e.frequency_hz, 0.0);
    EXPECT_EQ(e.take, 0);
  }
  // Nothing to reconstruct moments from.
  EXPECT_FALSE(both.options().HasAllHarmonics());
  EXPECT_TRUE(both.options().DeliversDepth());
  EXPECT_TRUE(both.options().MeasuredHarmonics().empty());
  EXPECT_EQ(both.options().UnambiguousRangeM(), 8.0);
  EXPECT_EQ(both.options().MissingHarmonicsText("SLICES"),
            "the source delivers depth, not modulated captures: SLICES needs modulated captures");
}

TEST(DepthSchedule, IndexOfTellsDepthFromAmplitudeAndFromModulatedExposures) {
  const AcquisitionSchedule schedule = MakeSchedule(DepthCamera(true));
  ExposureConfig frame = schedule.exposures()[1];
  frame.cycle = 12;
  frame.sequence = 25;
  EXPECT_THAT(schedule.IndexOf(frame), IsOkAndHolds(1));
  frame.content = FrameContent::kDepth;
  EXPECT_THAT(schedule.IndexOf(frame), IsOkAndHolds(0));
  frame.content = FrameContent::kModulated;  // an unmodulated exposure of the same metadata
  EXPECT_THAT(schedule.IndexOf(frame).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("not an exposure")));
  // And a modulated schedule's unmodulated exposure is not a depth frame.
  ScheduleOptions pair;
  pair.sampling = SamplingScheme::kFourBucket;
  const AcquisitionSchedule modulated = MakeSchedule(pair);
  ExposureConfig on = modulated.exposures()[0];
  EXPECT_THAT(modulated.IndexOf(on), IsOkAndHolds(0));
  on.content = FrameContent::kDepth;
  EXPECT_THAT(modulated.IndexOf(on).status(), StatusIs(absl::StatusCode::kInvalidArgument,
                                                        HasSubstr("depth (Z, m), take 0")));
}

TEST(DepthSchedule, ValidateNamesTheMaxDepthTakesAndHarmonics) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (double bad : {0.0, -1.0, nan, inf}) {
    ScheduleOptions options = DepthCamera(true);
    options.max_depth_m = bad;
    EXPECT_THAT(options.Validate(),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         HasSubstr("Violated constraint: finite and > 0 with sampling = depth")))
        << bad;
    EXPECT_FALSE(AcquisitionSchedule::Create(options).ok());
  }
  ScheduleOptions takes = DepthCamera(false);
  takes.takes = 2;
  EXPECT_THAT(takes.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                         HasSubstr("takes = 2. Violated constraint: takes = 1")));
  ScheduleOptions harmonics = DepthCamera(false);
  harmonics.harmonics = {1, 2};
  harmonics.order = 2;
  EXPECT_THAT(harmonics.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("harmonics = 1,2")));
  // The depth fields belong to depth schedules only.
  ScheduleOptions modulated;
  modulated.max_depth_m = 8.0;
  EXPECT_THAT(modulated.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("max_depth_m = 8. Violated constraint: 0 unless sampling = depth")));
  modulated.max_depth_m = 0.0;
  modulated.depth_amplitude = true;
  EXPECT_THAT(modulated.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("depth_amplitude = true")));
  EXPECT_THAT(DepthCamera(true).Validate(), IsOk());
}

TEST(DepthSchedule, IsDescribedAndNamedButNeverParsedFromText) {
  EXPECT_EQ(MakeSchedule(DepthCamera(true)).Describe(),
            "depth camera (Z up to 8 m), with amplitude: 2 raw frames");
  EXPECT_EQ(MakeSchedule(DepthCamera(false)).Describe(), "depth camera (Z up to 8 m): 1 raw frame");
  EXPECT_EQ(SamplingSchemeName(SamplingScheme::kDepth), "depth");
  EXPECT_EQ(FrameContentName(FrameContent::kAmplitude), "amplitude");
  // A URI key or a file attribute never makes a depth schedule.
  EXPECT_THAT(ParseSamplingScheme("depth").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("only its source declares")));
  EXPECT_EQ(DescribeExposure(MakeSchedule(DepthCamera(true)).exposures()[1]), "amplitude, take 0");
}

TEST(DepthSchedule, ModulatedSchedulesKeepTheirUnambiguousRange) {
  ScheduleOptions options;  // 23 MHz
  EXPECT_DOUBLE_EQ(options.UnambiguousRangeM(), 299792458.0 / (2.0 * 23e6));
  EXPECT_EQ(options.MissingHarmonicsText("SLICES"), "");
}

}  // namespace
}  // namespace transient
