#include "transient/reconstruct/demodulation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "tests/reconstruct/synthetic_cycles.h"
#include "tests/support/status_matchers.h"
#include "transient/reconstruct/kernels.h"

namespace transient {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

// Raw values are ~60 sensor units in float32 (ulp ~4e-6); a phasor is a few differences of them
// divided by |g| >= 0.6.
constexpr double kFloatTolerance = 1e-4;

using testing::MakeSchedule;
using testing::RandomScene;
using testing::Scene;
using testing::Synthesize;
using testing::SynthesizeCycle;

Demodulator MakeDemodulator(const AcquisitionSchedule& schedule, ImageGeometry geometry,
                            const DemodulationOptions& options = {}) {
  absl::StatusOr<Demodulator> d = Demodulator::Create(schedule, geometry, options);
  EXPECT_THAT(d.status(), IsOk());
  return *std::move(d);
}

// Double-precision oracle: the mean of each exposure over the takes not in `excluded` (schedule
// indices), then the four-bucket phasor divided by the nominal gain.
std::vector<std::vector<Complex>> ReferenceMoments(const AcquisitionSchedule& schedule,
                                                   const std::vector<RawFrame>& ordered,
                                                   const std::set<int>& excluded = {}) {
  const int e_count = schedule.exposures_per_take();
  const int takes = schedule.options().takes;
  const int64_t n = ordered.front().geometry.pixel_count();
  std::vector<std::vector<double>> mean(static_cast<size_t>(e_count),
                                        std::vector<double>(static_cast<size_t>(n), 0.0));
  for (int e = 0; e < e_count; ++e) {
    int used = 0;
    for (int t = 0; t < takes; ++t) {
      if (excluded.count(t * e_count + e)) continue;
      ++used;
      for (int64_t p = 0; p < n; ++p) mean[e][p] += ordered[t * e_count + e].pixels[p];
    }
    for (double& v : mean[e]) v /= used;
  }
  const int m = schedule.order();
  std::vector<std::vector<Complex>> c(static_cast<size_t>(m + 1),
                                      std::vector<Complex>(static_cast<size_t>(n)));
  const Complex g = schedule.nominal_gain();
  int e = 0;
  if (schedule.options().zeroth == ZerothScheme::kUnmodulatedPair) {
    for (int64_t p = 0; p < n; ++p) c[0][p] = mean[0][p] - mean[1][p];
    e = 2;
  } else if (schedule.options().zeroth == ZerothScheme::kLowFrequencyProxy) {
    for (int64_t p = 0; p < n; ++p) {
      c[0][p] = std::abs(Complex(mean[0][p] - mean[2][p], mean[1][p] - mean[3][p]) * 0.5 / g);
    }
    e = 4;
  }
  for (int j = 1; j <= m; ++j, e += 4) {
    for (int64_t p = 0; p < n; ++p) {
      c[j][p] = Complex(mean[e][p] - mean[e + 2][p], mean[e + 1][p] - mean[e + 3][p]) * 0.5 / g;
    }
  }
  return c;
}

double MaxError(const MomentImage& out, const std::vector<std::vector<Complex>>& expected,
                int plane) {
  double worst = 0.0;
  for (int64_t p = 0; p < out.geometry.pixel_count(); ++p) {
    const Complex got(out.real_plane(plane)[p], plane == 0 ? 0.0f : out.imag_plane(plane)[p]);
    worst = std::max(worst, std::abs(got - expected[plane][p]));
  }
  return worst;
}

TEST(Demodulator, RecoversKnownMomentsForEverySamplingAndZerothScheme) {
  const ImageGeometry geometry{7, 5};
  std::mt19937_64 rng(1);
  struct Sampling {
    SamplingScheme scheme;
    int steps;
  };
  for (Sampling sampling :
       {Sampling{SamplingScheme::kFourBucket, 1}, Sampling{SamplingScheme::kArccos, 8},
        Sampling{SamplingScheme::kHarmonicCancellation, 3}}) {
    for (ZerothScheme zeroth : {ZerothScheme::kUnmodulatedPair, ZerothScheme::kLowFrequencyProxy,
                                ZerothScheme::kEstimated}) {
      SCOPED_TRACE(::testing::Message()
                   << SamplingSchemeName(sampling.scheme) << ", " << ZerothSchemeName(zeroth));
      const AcquisitionSchedule schedule = MakeSchedule(sampling.scheme, sampling.steps, zeroth, 1);
      const Scene scene = RandomScene(geometry, 3, rng);
      std::vector<RawFrame> frames = SynthesizeCycle(schedule, scene, 4, 0.0, rng);
      std::shuffle(frames.begin(), frames.end(), rng);  // any order
      Demodulator demodulator = MakeDemodulator(schedule, geometry);
      MomentImage out;
      DemodulationReport report;
      ASSERT_THAT(demodulator.Demodulate(frames, &out, &report), IsOk());
      ASSERT_THAT(out.Validate(), IsOk());
      EXPECT_EQ(report.cycle, 4);
      EXPECT_EQ(report.frames_used, schedule.raw_frames_per_frame());
      EXPECT_TRUE(report.rejected.empty());
      EXPECT_EQ(report.saturated_pixels, 0);
      for (int64_t p = 0; p < geometry.pixel_count(); ++p) {
        ASSERT_EQ(out.valid[p], 1);
        ASSERT_EQ(out.flags[p], 0);
        const double c0_expected = zeroth == ZerothScheme::kEstimated ? 0.0 : scene.c0[p];
        EXPECT_NEAR(out.real_plane(0)[p], c0_expected, kFloatTolerance);
        for (int j = 1; j <= 3; ++j) {
          EXPECT_NEAR(out.real_plane(j)[p], scene.c[j][p].real(), kFloatTolerance);
          EXPECT_NEAR(out.imag_plane(j)[p], scene.c[j][p].imag(), kFloatTolerance);
        }
      }
    }
  }
}

// The planes are demodulated over blocks of pixels on the kernels' threads: an image of several
// blocks gives the same values bit for bit on one thread and on two, and the scene's moments.
TEST(Demodulator, SeveralBlocksOfPixelsOnOneOrTwoThreadsGiveTheSameValues) {
  const KernelOptions saved = GetKernelOptions();
  const ImageGeometry geometry{163, 120};  // 19,560 pixels: three blocks of the demodulation
  std::mt19937_64 rng(7);
  for (ZerothScheme zeroth : {ZerothScheme::kUnmodulatedPair, ZerothScheme::kLowFrequencyProxy,
                              ZerothScheme::kEstimated}) {
    SCOPED_TRACE(ZerothSchemeName(zeroth));
    const AcquisitionSchedule schedule = MakeSchedule(SamplingScheme::kFourBucket, 1, zeroth, 1);
    const Scene scene = RandomScene(geometry, 3, rng);
    const std::vector<RawFrame> frames = SynthesizeCycle(schedule, scene, 0, 0.0, rng);
    MomentImage one_thread, two_threads;
    SetKernelOptions({.threads = 1});
    ASSERT_THAT(MakeDemodulator(schedule, geometry).Demodulate(frames, &one_thread, nullptr),
                IsOk());
    SetKernelOptions({.threads = 2});
    ASSERT_THAT(MakeDemodulator(schedule, geometry).Demodulate(frames, &two_threads, nullptr),
                IsOk());
    SetKernelOptions(saved);
    EXPECT_EQ(two_threads.real, one_thread.real);
    EXPECT_EQ(two_threads.imag, one_thread.imag);
    EXPECT_EQ(two_threads.valid, one_thread.valid);
    for (int64_t p = 0; p < geometry.pixel_count(); p += 97) {  // the last block too
      const double c0_expected = zeroth == ZerothScheme::kEstimated ? 0.0 : scene.c0[p];
      EXPECT_NEAR(two_threads.real_plane(0)[p], c0_expected, kFloatTolerance);
      for (int j = 1; j <= 3; ++j) {
        EXPECT_NEAR(two_threads.real_plane(j)[p], scene.c[j][p].real(), kFloatTolerance);
        EXPECT_NEAR(two_threads.imag_plane(j)[p], scene.c[j][p].imag(), kFloatTolerance);
      }
    }
  }
}

TEST(Demodulator, FourBucketKeepsTheThirdHarmonicThatArccosSamplingSuppresses) {
  // A square-wave effective modulation (odd harmonics 1/k) measured in four buckets: the third
  // harmonic aliases into c_1 (thesis §8.3.1), arccos sampling with n_phi = 8 reduces it.
  const ImageGeometry geometry{1, 1};
  double four_bucket_error = 0.0;
  for (auto [scheme, steps] :
       {std::pair{SamplingScheme::kFourBucket, 1}, std::pair{SamplingScheme::kArccos, 8}}) {
    const AcquisitionSchedule schedule =
        MakeSchedule(scheme, steps, ZerothScheme::kEstimated, 1, 1);
    const double tau_phase = 1.0;  // phase of a Dirac return at the base frequency
    std::vector<RawFrame> frames;
    for (const ExposureConfig& config : schedule.exposures()) {
      double value = 10.0;
      for (const SubExposure& s : schedule.sub_exposures()) {
        const double shift = config.phase_shift_rad + s.phase_shift_rad;
        for (int k = 1; k <= 15; k += 2) {  // square wave: sum over odd k of cos(k x)/k
          value += s.weight * std::cos(k * (tau_phase - shift)) / k;
        }
      }
      RawFrame frame;
      frame.config = config;
      frame.geometry = geometry;
      frame.pixels = {static_cast<float>(value)};
      frames.push_back(frame);
    }
    Demodulator demodulator = MakeDemodulator(schedule, geometry);
    MomentImage out;
    ASSERT_THAT(demodulator.Demodulate(frames, &out), IsOk());
    const double phase = std::arg(Complex(out.real_plane(1)[0], out.imag_plane(1)[0]));
    const double phase_error = std::abs(std::remainder(phase - tau_phase, 2.0 * std::numbers::pi));
    if (scheme == SamplingScheme::kFourBucket) {
      four_bucket_error = phase_error;
      EXPECT_GT(phase_error, 0.1);  // the 3rd harmonic folds onto the -1st: 0.14 rad at tau = 1
    } else {
      // n_phi = 8 suppresses the odd harmonics, not entirely (fig. 8.2): 0.026 rad remain.
      EXPECT_LT(phase_error, 0.25 * four_bucket_error);
    }
  }
}

// N-step sampling of a harmonic set (the Kinect v2's {10, 2, 15} with N = 3, and others):
// the measured planes hold c_j, the others 0.
TEST(Demodulator, NStepSamplingOfAHarmonicSetRecoversTheMeasuredMoments) {
  const ImageGeometry geometry{7, 5};
  std::mt19937_64 rng(11);
  for (int buckets : {3, 5, 8}) {
    ScheduleOptions o;
    o.base_frequency_hz = 8e6;
    o.order = 15;
    o.harmonics = {10, 2, 15};
    o.buckets = buckets;
    o.sampling = SamplingScheme::kFourBucket;
    o.zeroth = ZerothScheme::kEstimated;
    absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(o);
    ASSERT_THAT(schedule.status(), IsOk());
    const Scene scene = RandomScene(geometry, 15, rng);
    Demodulator demodulator = MakeDemodulator(*schedule, geometry);
    MomentImage out;
    ASSERT_THAT(demodulator.Demodulate(SynthesizeCycle(*schedule, scene, 0, 0.0, rng), &out),
                IsOk());
    ASSERT_EQ(out.order, 15);
    for (int j = 1; j <= 15; ++j) {
      const bool measured = j == 2 || j == 10 || j == 15;
      for (int64_t p = 0; p < geometry.pixel_count(); ++p) {
        const Complex want = measured ? scene.c[j][p] : Complex(0.0, 0.0);
        EXPECT_NEAR(out.real_plane(j)[p], want.real(), kFloatTolerance) << buckets << " " << j;
        EXPECT_NEAR(out.imag_plane(j)[p], want.imag(), kFloatTolerance) << buckets << " " << j;
      }
    }
  }
}

// What N-step sampling aliases (acquisition.h, ScheduleOptions::buckets): an effective
// modulation cos(x) + a_h cos(h x) puts the h-th harmonic into the estimate of c_1 exactly when
// h = +-1 (mod N). Three steps alias the 2nd harmonic and cancel the 3rd; four steps the reverse.
TEST(Demodulator, NStepSamplingAliasesExactlyTheHarmonicsCongruentToPlusMinusOne) {
  const ImageGeometry geometry{1, 1};
  const double tau_phase = 1.0;
  for (int buckets : {3, 4, 5}) {
    for (int h = 2; h <= 6; ++h) {
      ScheduleOptions o;
      o.order = 1;
      o.buckets = buckets;
      o.sampling = SamplingScheme::kFourBucket;
      o.zeroth = ZerothScheme::kEstimated;
      absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(o);
      ASSERT_THAT(schedule.status(), IsOk());
      std::vector<RawFrame> frames;
      for (const ExposureConfig& config : schedule->exposures()) {
        const double x = tau_phase - config.phase_shift_rad;
        RawFrame frame;
        frame.config = config;
        frame.geometry = geometry;
        frame.pixels = {static_cast<float>(10.0 + std::cos(x) + 0.3 * std::cos(h * x))};
        frames.push_back(frame);
      }
      Demodulator demodulator = MakeDemodulator(*schedule, geometry);
      MomentImage out;
      ASSERT_THAT(demodulator.Demodulate(frames, &out), IsOk());
      const double error =
          std::abs(Complex(out.real_plane(1)[0], out.imag_plane(1)[0]) - std::polar(1.0, tau_phase));
      const bool aliases = (h - 1) % buckets == 0 || (h + 1) % buckets == 0;
      if (aliases) {
        EXPECT_NEAR(error, 0.3, 0.3 * 1e-4) << "N = " << buckets << ", h = " << h;
      } else {
        EXPECT_LT(error, 1e-5) << "N = " << buckets << ", h = " << h;
      }
    }
  }
}

TEST(Demodulator, RefusesADepthCamerasSchedule) {
  ScheduleOptions depth;
  depth.sampling = SamplingScheme::kDepth;
  depth.max_depth_m = 5.0;
  absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(depth);
  ASSERT_THAT(schedule.status(), IsOk());
  EXPECT_THAT(Demodulator::Create(*schedule, ImageGeometry{4, 3}, {}).status(),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("the source delivers depth, not modulated captures: "
                                 "demodulation needs modulated captures")));
}

TEST(Demodulator, RefusesIncompleteDuplicatedForeignAndMismatchedCycles) {
  const ImageGeometry geometry{4, 3};
  std::mt19937_64 rng(2);
  const AcquisitionSchedule schedule =
      MakeSchedule(SamplingScheme::kArccos, 8, ZerothScheme::kUnmodulatedPair, 2);
  const Scene scene = RandomScene(geometry, 3, rng);
  const std::vector<RawFrame> good = SynthesizeCycle(schedule, scene, 8, 0.0, rng);
  Demodulator demodulator = MakeDemodulator(schedule, geometry);
  MomentImage out;
  out.order = 99;  // a sentinel: refused calls leave `out` alone
  const auto refused = [&](const std::vector<RawFrame>& frames, absl::string_view text) {
    EXPECT_THAT(demodulator.Demodulate(frames, &out),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(text)));
    EXPECT_EQ(out.order, 99);
  };

  std::vector<RawFrame> missing = good;
  missing.erase(missing.begin() + 5);
  refused(missing, "missing " + DescribeExposure(good[5].config));
  refused({}, "lacks 28 of 28 exposures");

  std::vector<RawFrame> duplicated = good;
  duplicated[9] = good[3];
  refused(duplicated, DescribeFrame(good[3].config) + " duplicates the exposure of frame");

  std::vector<RawFrame> foreign = good;
  foreign[2].config.harmonic = 5;
  foreign[2].config.frequency_hz = 5 * schedule.options().base_frequency_hz;
  refused(foreign, "is not an exposure of the schedule");

  std::vector<RawFrame> other_cycle = good;
  other_cycle[7].config.cycle = 9;
  refused(other_cycle, "belongs to cycle 9");

  std::vector<RawFrame> short_frame = good;
  short_frame[4].pixels.resize(11);
  refused(short_frame, "holds 11 pixels. Violated constraint: pixels == width*height = 12");

  std::vector<RawFrame> other_geometry = good;
  other_geometry[1].geometry = ImageGeometry{3, 4};
  refused(other_geometry, "has geometry 3x4; the demodulator expects 4x3");

  EXPECT_THAT(demodulator.Demodulate(good, &out), IsOk());
  EXPECT_EQ(out.order, 3);
}

TEST(Demodulator, AveragingTakesReducesNoiseLikeOneOverSqrtTakes) {
  const ImageGeometry geometry{64, 64};  // 4096 pixels: the RMS is known to ~1 %
  constexpr double kSigma = 0.5;
  constexpr int kTakes = 16;
  std::mt19937_64 rng(3);
  double rms[2];
  for (int k = 0; k < 2; ++k) {
    const int takes = k == 0 ? 1 : kTakes;
    const AcquisitionSchedule schedule =
        MakeSchedule(SamplingScheme::kArccos, 8, ZerothScheme::kUnmodulatedPair, takes);
    const Scene scene = RandomScene(geometry, 3, rng);
    Demodulator demodulator = MakeDemodulator(schedule, geometry);
    MomentImage out;
    DemodulationReport report;
    ASSERT_THAT(
        demodulator.Demodulate(SynthesizeCycle(schedule, scene, 0, kSigma, rng), &out, &report),
        IsOk());
    EXPECT_TRUE(report.rejected.empty());
    double sum = 0.0;
    for (int64_t p = 0; p < geometry.pixel_count(); ++p) {
      sum += std::norm(Complex(out.real_plane(1)[p], out.imag_plane(1)[p]) - scene.c[1][p]);
    }
    rms[k] = std::sqrt(sum / geometry.pixel_count());
  }
  // sqrt(16) = 4; the sample RMS of 4096 pixels has a relative spread of about 1 %.
  EXPECT_NEAR(rms[0] / rms[1], std::sqrt(kTakes), 0.1 * std::sqrt(kTakes));
}

TEST(Demodulator, CleanNoisyTakesAreNeverRejected) {
  const ImageGeometry geometry{40, 30};
  std::mt19937_64 rng(4);
  const AcquisitionSchedule schedule =
      MakeSchedule(SamplingScheme::kArccos, 8, ZerothScheme::kLowFrequencyProxy, 10);
  Demodulator demodulator = MakeDemodulator(schedule, geometry);
  const Scene scene = RandomScene(geometry, 3, rng);
  for (int cycle = 0; cycle < 20; ++cycle) {
    MomentImage out;
    DemodulationReport report;
    ASSERT_THAT(
        demodulator.Demodulate(SynthesizeCycle(schedule, scene, cycle, 1.0, rng), &out, &report),
        IsOk());
    EXPECT_TRUE(report.rejected.empty()) << "cycle " << cycle;
    EXPECT_EQ(report.frames_used, schedule.raw_frames_per_frame());
  }
}

TEST(Demodulator, NoiseFreeTakesAreNeverRejected) {
  // All takes identical up to float rounding: the median score is ~0 and the floor must hold.
  const ImageGeometry geometry{16, 8};
  std::mt19937_64 rng(5);
  const AcquisitionSchedule schedule =
      MakeSchedule(SamplingScheme::kFourBucket, 1, ZerothScheme::kUnmodulatedPair, 5);
  const Scene scene = RandomScene(geometry, 3, rng);
  std::vector<RawFrame> frames = SynthesizeCycle(schedule, scene, 0, 0.0, rng);
  frames[3].pixels[0] = std::nextafter(frames[3].pixels[0], 1e9f);  // one-ulp disagreement
  for (float& v : frames[20].pixels) v = std::nextafter(v, 1e9f);
  Demodulator demodulator = MakeDemodulator(schedule, geometry);
  MomentImage out;
  DemodulationReport report;
  ASSERT_THAT(demodulator.Demodulate(frames, &out, &report), IsOk());
  EXPECT_TRUE(report.rejected.empty());
}

TEST(Demodulator, OutlierTakesAreRejectedAndTheResultIsTheCleanAverage) {
  const ImageGeometry geometry{40, 30};
  constexpr double kSigma = 0.1;
  std::mt19937_64 rng(6);
  const AcquisitionSchedule schedule =
      MakeSchedule(SamplingScheme::kArccos, 8, ZerothScheme::kUnmodulatedPair, 10);
  const Scene scene = RandomScene(geometry, 3, rng);
  std::vector<RawFrame> frames = SynthesizeCycle(schedule, scene, 0, kSigma, rng);
  const int e_count = schedule.exposures_per_take();
  // Synchronisation failures of the prototype (thesis §8.5): a phase slip of 1 rad in take 3
  // of harmonic 2, a 15 % brighter capture in take 7 of the unmodulated pair, and a phase slip in
  // take 0 of harmonic 3.
  const int slipped = 3 * e_count + 2 + 4 + 1;
  const int brighter = 7 * e_count + 0;
  const int slipped2 = 0 * e_count + 2 + 8 + 2;
  const auto corrupt = [&](int i, double scale, double slip) {
    frames[i] = Synthesize(schedule, scene, schedule.exposures()[i], 0, frames[i].config.sequence,
                           kSigma, rng, scale, slip);
  };
  corrupt(slipped, 1.0, 1.0);
  corrupt(brighter, 1.15, 0.0);
  corrupt(slipped2, 1.0, 1.0);

  Demodulator demodulator = MakeDemodulator(schedule, geometry);
  MomentImage out;
  DemodulationReport report;
  ASSERT_THAT(demodulator.Demodulate(frames, &out, &report), IsOk());
  std::set<uint64_t> rejected;
  for (const ExposureConfig& c : report.rejected) rejected.insert(c.sequence);
  EXPECT_EQ(rejected,
            (std::set<uint64_t>{frames[slipped].config.sequence, frames[brighter].config.sequence,
                                frames[slipped2].config.sequence}));
  EXPECT_EQ(report.frames_used, schedule.raw_frames_per_frame() - 3);
  const auto expected = ReferenceMoments(schedule, frames, {slipped, brighter, slipped2});
  for (int j = 0; j <= 3; ++j) EXPECT_LT(MaxError(out, expected, j), kFloatTolerance) << j;
  // Without rejection the outliers would have shown: the check above can fail.
  const auto polluted = ReferenceMoments(schedule, frames);
  EXPECT_GT(MaxError(out, polluted, 2), 100 * kFloatTolerance);
}

TEST(Demodulator, TwoTakesAreAveragedWithoutRejection) {
  const ImageGeometry geometry{8, 8};
  std::mt19937_64 rng(7);
  const AcquisitionSchedule schedule =
      MakeSchedule(SamplingScheme::kFourBucket, 1, ZerothScheme::kEstimated, 2);
  const Scene scene = RandomScene(geometry, 3, rng);
  std::vector<RawFrame> frames = SynthesizeCycle(schedule, scene, 0, 0.1, rng);
  frames[14] = Synthesize(schedule, scene, schedule.exposures()[14], 0, 14, 0.1, rng, 1.5);
  Demodulator demodulator = MakeDemodulator(schedule, geometry);
  MomentImage out;
  DemodulationReport report;
  ASSERT_THAT(demodulator.Demodulate(frames, &out, &report), IsOk());
  EXPECT_TRUE(report.rejected.empty());  // two frames cannot outvote each other
  const auto expected = ReferenceMoments(schedule, frames);
  for (int j = 1; j <= 3; ++j) EXPECT_LT(MaxError(out, expected, j), kFloatTolerance);
}

TEST(Demodulator, SaturatedAndUnreadablePixelsAreInvalidAndFlagged) {
  const ImageGeometry geometry{6, 4};
  std::mt19937_64 rng(8);
  const AcquisitionSchedule schedule =
      MakeSchedule(SamplingScheme::kArccos, 8, ZerothScheme::kUnmodulatedPair, 1);
  const Scene scene = RandomScene(geometry, 3, rng);
  std::vector<RawFrame> frames = SynthesizeCycle(schedule, scene, 0, 0.0, rng);
  constexpr float kLevel = 1000.0f;
  for (RawFrame& f : frames) f.saturation_level = kLevel;
  frames[0].pixels[3] = kLevel;           // at the level counts as saturated
  frames[9].pixels[10] = 5000.0f;         // above it
  frames[13].pixels[17] = std::nanf("");  // unreadable
  Demodulator demodulator = MakeDemodulator(schedule, geometry);
  MomentImage out;
  DemodulationReport report;
  ASSERT_THAT(demodulator.Demodulate(frames, &out, &report), IsOk());
  EXPECT_EQ(report.saturated_pixels, 3);
  for (int64_t p = 0; p < geometry.pixel_count(); ++p) {
    const bool bad = p == 3 || p == 10 || p == 17;
    EXPECT_EQ(out.valid[p], bad ? 0 : 1) << p;
    EXPECT_EQ(out.flags[p], bad ? kFlagSaturated : 0) << p;
    for (int j = 0; j <= 3; ++j) {
      EXPECT_EQ(std::isnan(out.real_plane(j)[p]), bad) << p;
      if (!bad && j >= 1) {
        EXPECT_NEAR(out.real_plane(j)[p], scene.c[j][p].real(), kFloatTolerance);
      }
    }
  }
}

TEST(Demodulator, RejectedTakesDoNotSaturateThePixel) {
  const ImageGeometry geometry{20, 20};
  std::mt19937_64 rng(9);
  const AcquisitionSchedule schedule =
      MakeSchedule(SamplingScheme::kFourBucket, 1, ZerothScheme::kEstimated, 5);
  const Scene scene = RandomScene(geometry, 3, rng);
  std::vector<RawFrame> frames = SynthesizeCycle(schedule, scene, 0, 0.2, rng);
  for (RawFrame& f : frames) f.saturation_level = 200.0f;
  frames[13] = Synthesize(schedule, scene, schedule.exposures()[13], 0, 13, 0.2, rng, 3.0);
  frames[13].saturation_level = 200.0f;
  frames[13].pixels[5] = 300.0f;
  Demodulator demodulator = MakeDemodulator(schedule, geometry);
  MomentImage out;
  DemodulationReport report;
  ASSERT_THAT(demodulator.Demodulate(frames, &out, &report), IsOk());
  ASSERT_EQ(report.rejected.size(), 1u);
  EXPECT_EQ(report.rejected[0].sequence, 13u);
  EXPECT_EQ(report.saturated_pixels, 0);
  EXPECT_EQ(out.valid[5], 1);
}

class VideoTest : public ::testing::Test {
 protected:
  static constexpr double kSigma = 0.05;
  const ImageGeometry geometry_{30, 20};
  std::mt19937_64 rng_{10};
  const AcquisitionSchedule schedule_ =
      MakeSchedule(SamplingScheme::kArccos, 8, ZerothScheme::kUnmodulatedPair, 1);
  const Scene scene_ = RandomScene(geometry_, 3, rng_);

  Demodulator MakeVideo() {
    DemodulationOptions options;
    options.video = true;
    return MakeDemodulator(schedule_, geometry_, options);
  }
  // Frame index 2 + 4*(j-1) + b is harmonic j's bucket b; 0 and 1 are the pair.
  std::vector<RawFrame> Cycle(int64_t cycle, int corrupt = -1, double scale = 1.0,
                              double slip = 0.0) {
    std::vector<RawFrame> frames = SynthesizeCycle(schedule_, scene_, cycle, kSigma, rng_);
    if (corrupt >= 0) {
      frames[corrupt] = Synthesize(schedule_, scene_, schedule_.exposures()[corrupt], cycle,
                                   frames[corrupt].config.sequence, kSigma, rng_, scale, slip);
    }
    return frames;
  }
};

TEST_F(VideoTest, AnOutlierCaptureIsFilledFromThePreviousCycleAndFlagged) {
  Demodulator video = MakeVideo();
  MomentImage previous, out;
  DemodulationReport report;
  for (int cycle = 0; cycle < 5; ++cycle) {
    ASSERT_THAT(video.Demodulate(Cycle(cycle), &previous, &report), IsOk());
    EXPECT_TRUE(report.rejected.empty());
    EXPECT_TRUE(report.filled_planes.empty());
  }
  const int corrupt = 2 + 4 * 1 + 1;  // harmonic 2, bucket pi/2
  const std::vector<RawFrame> frames = Cycle(5, corrupt, 1.0, 0.5);
  ASSERT_THAT(video.Demodulate(frames, &out, &report), IsOk());
  ASSERT_EQ(report.rejected.size(), 1u);
  EXPECT_EQ(report.rejected[0].sequence, frames[corrupt].config.sequence);
  EXPECT_THAT(report.filled_planes, ElementsAre(2));
  EXPECT_EQ(report.filled_pixels, geometry_.pixel_count());
  EXPECT_EQ(report.frames_used, schedule_.raw_frames_per_frame() - 4);  // plane 2 not measured
  const auto fresh = ReferenceMoments(schedule_, frames);
  for (int64_t p = 0; p < geometry_.pixel_count(); ++p) {
    EXPECT_EQ(out.flags[p], kFlagOutlierFilled);
    EXPECT_EQ(out.valid[p], 1);
    EXPECT_EQ(out.real_plane(2)[p], previous.real_plane(2)[p]);
    EXPECT_EQ(out.imag_plane(2)[p], previous.imag_plane(2)[p]);
  }
  for (int j : {0, 1, 3}) EXPECT_LT(MaxError(out, fresh, j), kFloatTolerance) << j;

  // The next clean cycle is measured again, without flags.
  ASSERT_THAT(video.Demodulate(Cycle(6), &out, &report), IsOk());
  EXPECT_TRUE(report.filled_planes.empty());
  EXPECT_EQ(out.flags[0], 0);
}

TEST_F(VideoTest, NothingIsRejectedBeforeThereIsHistory) {
  Demodulator video = MakeVideo();
  MomentImage out;
  DemodulationReport report;
  // Cycles 0..3 find 0, 0, 1, 2 < kMinVideoScores earlier scores per exposure: an outlier in
  // cycle 3 passes.
  for (int cycle = 0; cycle <= kMinVideoScores; ++cycle) {
    ASSERT_THAT(
        video.Demodulate(Cycle(cycle, cycle == kMinVideoScores ? 5 : -1, 1.5), &out, &report),
        IsOk());
    EXPECT_TRUE(report.rejected.empty()) << cycle;
  }
  // From the next cycle on, an outlier of an exposure with history is caught. (Exposure 5 itself
  // is compared with the outlier it accepted: that is the price of judging without history.)
  const std::vector<RawFrame> frames = Cycle(kMinVideoScores + 1, 9, 1.5);
  ASSERT_THAT(video.Demodulate(frames, &out, &report), IsOk());
  std::set<uint64_t> rejected;
  for (const ExposureConfig& c : report.rejected) rejected.insert(c.sequence);
  EXPECT_TRUE(rejected.count(frames[9].config.sequence));
  EXPECT_FALSE(rejected.count(frames[8].config.sequence));
}

TEST_F(VideoTest, ABrightnessChangeOfTheWholeSceneIsNotAnOutlier) {
  Demodulator video = MakeVideo();
  MomentImage out;
  DemodulationReport report;
  for (int cycle = 0; cycle < 6; ++cycle) {
    ASSERT_THAT(video.Demodulate(Cycle(cycle), &out, &report), IsOk());
  }
  // Every frame 30 % brighter (the light or the scene changed): all scores rise together.
  std::vector<RawFrame> frames = Cycle(6);
  for (RawFrame& f : frames) {
    for (float& v : f.pixels) v *= 1.3f;
  }
  ASSERT_THAT(video.Demodulate(frames, &out, &report), IsOk());
  EXPECT_TRUE(report.rejected.empty());
  EXPECT_TRUE(report.filled_planes.empty());
}

TEST_F(VideoTest, ALastingChangeOfOneExposureIsAcceptedAfterTheFillLimit) {
  DemodulationOptions options;
  options.video = true;
  options.video_max_consecutive_fills = 2;
  Demodulator video = MakeDemodulator(schedule_, geometry_, options);
  MomentImage out;
  DemodulationReport report;
  for (int cycle = 0; cycle < 5; ++cycle) {
    ASSERT_THAT(video.Demodulate(Cycle(cycle), &out, &report), IsOk());
  }
  std::vector<int> filled;
  for (int cycle = 5; cycle < 9; ++cycle) {
    ASSERT_THAT(video.Demodulate(Cycle(cycle, 0, 1.4), &out, &report), IsOk());
    filled.push_back(static_cast<int>(report.filled_planes.size()));
  }
  EXPECT_THAT(filled, ElementsAre(1, 1, 0, 0));
}

TEST(Demodulator, HandlesAFullSensorCycle) {
  // The prototype's 163x120 sensor (thesis §8.5) with 16 raw frames: correct at full size.
  const ImageGeometry geometry{163, 120};
  std::mt19937_64 rng(11);
  const AcquisitionSchedule schedule =
      MakeSchedule(SamplingScheme::kArccos, 8, ZerothScheme::kLowFrequencyProxy, 1);
  const Scene scene = RandomScene(geometry, 3, rng);
  Demodulator demodulator = MakeDemodulator(schedule, geometry);
  MomentImage out;
  ASSERT_THAT(demodulator.Demodulate(SynthesizeCycle(schedule, scene, 0, 0.0, rng), &out), IsOk());
  EXPECT_NEAR(out.real_plane(0)[163 * 60 + 80], scene.c0[163 * 60 + 80], kFloatTolerance);
  EXPECT_NEAR(out.imag_plane(3)[163 * 119 + 162], scene.c[3][163 * 119 + 162].imag(),
              kFloatTolerance);
}

TEST(DemodulationOptions, ValidateNamesFieldValueAndRule) {
  EXPECT_THAT(DemodulationOptions().Validate(), IsOk());
  DemodulationOptions o;
  o.outlier_threshold = 0.5;
  EXPECT_THAT(o.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                     HasSubstr("outlier_threshold = 0.5. Violated constraint")));
  o = DemodulationOptions();
  o.outlier_relative_floor = -1;
  EXPECT_THAT(o.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                     HasSubstr("outlier_relative_floor = -1")));
  o = DemodulationOptions();
  o.video_threshold = std::nan("");
  EXPECT_THAT(o.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("video_threshold = nan")));
  o = DemodulationOptions();
  o.video_history = 2;
  EXPECT_THAT(o.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                     HasSubstr("video_history = 2. Violated constraint: 3 <=")));
  o = DemodulationOptions();
  o.video_max_consecutive_fills = 0;
  EXPECT_THAT(o.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                     HasSubstr("video_max_consecutive_fills = 0")));
  const AcquisitionSchedule schedule =
      MakeSchedule(SamplingScheme::kArccos, 8, ZerothScheme::kUnmodulatedPair, 1);
  EXPECT_THAT(Demodulator::Create(schedule, {4, 4}, o).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("video_max_consecutive")));
  EXPECT_THAT(Demodulator::Create(schedule, {0, 4}, {}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("geometry 0x4")));
}

}  // namespace
}  // namespace transient
