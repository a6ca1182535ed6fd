// The simulator as a CaptureSource: stream protocol, frame metadata, camera, ground truth of
// every scene, and the fixed pattern that belongs to the camera.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <set>
#include <cmath>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "tests/drivers/sim/sim_test_util.h"
#include "tests/support/status_matchers.h"
#include "kinect2/kinect2_format.h"
#include "transient/drivers/simulator.h"

namespace transient::sim::testing {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

constexpr absl::string_view kSmallFast = "pace=fast&width=24&height=16";

TEST(SimulatorSource, NextBeforeStartIsFailedPrecondition) {
  auto source = OpenOrDie(absl::StrCat("sim:mirrors?", kSmallFast));
  RawFrame frame;
  EXPECT_THAT(source->Next(absl::Seconds(1), &frame),
              StatusIs(absl::StatusCode::kFailedPrecondition, HasSubstr("before Start")));
  ASSERT_THAT(source->Start(), IsOk());
  EXPECT_THAT(source->Start(),
              StatusIs(absl::StatusCode::kFailedPrecondition, HasSubstr("already")));
  EXPECT_THAT(source->Next(absl::Seconds(1), &frame), IsOk());
  ASSERT_THAT(source->Stop(), IsOk());
  EXPECT_THAT(source->Next(absl::Seconds(1), &frame),
              StatusIs(absl::StatusCode::kFailedPrecondition, HasSubstr("before Start")));
}

TEST(SimulatorSource, FramesLimitEndsWithOutOfRangeAfterThatManyCycles) {
  auto source = OpenOrDie(absl::StrCat("sim:mirrors?frames=2&", kSmallFast));
  ASSERT_THAT(source->Start(), IsOk());
  RawFrame frame;
  const int expected = 2 * source->schedule().raw_frames_per_frame();
  for (int i = 0; i < expected; ++i) ASSERT_THAT(source->Next(absl::Seconds(1), &frame), IsOk());
  EXPECT_EQ(frame.config.cycle, 1);
  EXPECT_THAT(source->Next(absl::Seconds(1), &frame),
              StatusIs(absl::StatusCode::kOutOfRange, HasSubstr("2 transient frames")));
}

TEST(SimulatorSource, FramesFollowTheScheduleWithRunningMetadata) {
  auto source = OpenOrDie(absl::StrCat("sim:corner?takes=2&readout=1e-3&", kSmallFast));
  ASSERT_THAT(source->Start(), IsOk());
  const AcquisitionSchedule& schedule = source->schedule();
  const double period = 1.92e-3 + 1e-3;
  EXPECT_DOUBLE_EQ(source->camera().frame_period_s, period);
  RawFrame frame;
  for (int i = 0; i < 3 * schedule.raw_frames_per_frame(); ++i) {
    ASSERT_THAT(source->Next(absl::Seconds(1), &frame), IsOk());
    const ExposureConfig& expected = schedule.exposures()[i % schedule.raw_frames_per_frame()];
    EXPECT_EQ(frame.config.harmonic, expected.harmonic);
    EXPECT_EQ(frame.config.frequency_hz, expected.frequency_hz);
    EXPECT_EQ(frame.config.phase_shift_rad, expected.phase_shift_rad);
    EXPECT_EQ(frame.config.illumination, expected.illumination);
    EXPECT_EQ(frame.config.take, expected.take);
    EXPECT_EQ(frame.config.cycle, i / schedule.raw_frames_per_frame());
    EXPECT_EQ(frame.config.sequence, static_cast<uint64_t>(i));
    EXPECT_DOUBLE_EQ(frame.config.timestamp_s, i * period);
    EXPECT_THAT(schedule.IndexOf(frame.config).status(), IsOk());
    EXPECT_EQ(frame.geometry, (ImageGeometry{24, 16}));
    EXPECT_EQ(frame.pixels.size(), 24u * 16u);
  }
}

TEST(SimulatorSource, StopAndStartContinueTheSequence) {
  auto source = OpenOrDie(absl::StrCat("sim:sparse?", kSmallFast));
  RawFrame frame;
  ASSERT_THAT(source->Start(), IsOk());
  ASSERT_THAT(source->Next(absl::Seconds(1), &frame), IsOk());
  ASSERT_THAT(source->Stop(), IsOk());
  ASSERT_THAT(source->Start(), IsOk());
  ASSERT_THAT(source->Next(absl::Seconds(1), &frame), IsOk());
  EXPECT_EQ(frame.config.sequence, 1u);
}

// The fault injection: the camera is gone for the last unplug_for seconds of every
// unplug_every seconds, counted from the process's first simulator; Next and opening are then
// Unavailable, and once it is back a new source delivers again.
TEST(SimulatorSource, UnpluggedCameraIsUnavailableAndComesBack) {
  const std::string uri =
      absl::StrCat("sim:mirrors?", kSmallFast, "&unplug_every=0.6&unplug_for=0.3");
  // Wait for the plugged-in part of a period: opening works, then frames come until the
  // camera is gone.
  std::unique_ptr<CaptureSource> source;
  const absl::Time deadline = absl::Now() + absl::Seconds(30);
  absl::Status opened = absl::UnknownError("not tried");
  while (!opened.ok() && absl::Now() < deadline) {
    absl::StatusOr<std::unique_ptr<CaptureSource>> s = OpenSource(uri);
    opened = s.status();
    if (s.ok()) source = *std::move(s);
    if (!opened.ok()) {
      EXPECT_THAT(opened, StatusIs(absl::StatusCode::kUnavailable, HasSubstr("unplugged")));
      absl::SleepFor(absl::Milliseconds(20));
    }
  }
  ASSERT_THAT(opened, IsOk());
  ASSERT_THAT(source->Start(), IsOk());
  RawFrame frame;
  absl::Status next;
  int delivered = 0;
  while ((next = source->Next(absl::Seconds(1), &frame)).ok() && absl::Now() < deadline) {
    ++delivered;
  }
  EXPECT_GT(delivered, 0);
  EXPECT_THAT(next,
              StatusIs(absl::StatusCode::kUnavailable,
                       HasSubstr("the simulated camera is unplugged (0.3 s of every 0.6 s)")));
  // While it is gone, opening fails the same way; within a period it is back.
  bool refused = false, back = false;
  while (!back && absl::Now() < deadline) {
    absl::StatusOr<std::unique_ptr<CaptureSource>> again = OpenSource(uri);
    if (!again.ok()) {
      EXPECT_THAT(again.status(), StatusIs(absl::StatusCode::kUnavailable, HasSubstr("unplugged")));
      refused = true;
      absl::SleepFor(absl::Milliseconds(20));
    } else {
      back = refused;  // an open before the first refusal may precede the outage's end
      if (back) {
        ASSERT_THAT((*again)->Start(), IsOk());
        EXPECT_THAT((*again)->Next(absl::Seconds(1), &frame), IsOk());
      }
    }
  }
  EXPECT_TRUE(refused);
  EXPECT_TRUE(back);
}

TEST(SimulatorSource, RealtimePaceDeliversFramesAtTheFramePeriod) {
  // 10 ms frame period: frame 5 is due 50 ms after Start. Only a lower bound, measured from
  // before Start: a loaded machine may be slower, never faster.
  auto source =
      OpenOrDie("sim:mirrors?pace=realtime&width=16&height=12&exposure=1e-3&readout=9e-3");
  const absl::Time begin = absl::Now();
  ASSERT_THAT(source->Start(), IsOk());
  RawFrame frame;
  for (int i = 0; i < 6; ++i) ASSERT_THAT(source->Next(absl::Seconds(1), &frame), IsOk());
  EXPECT_GE(absl::Now() - begin, absl::Milliseconds(50));
}

TEST(SimulatorSource, FrameNotDueWithinTheTimeoutIsADeadlineAndComesLater) {
  // A 5 s frame period: the second frame is not due within 1 ms however loaded the machine
  // is (the first frame is due at once), and it is still delivered afterwards.
  auto source =
      OpenOrDie("sim:mirrors?pace=realtime&width=16&height=12&exposure=1e-3&readout=5");
  ASSERT_THAT(source->Start(), IsOk());
  RawFrame frame;
  ASSERT_THAT(source->Next(absl::Seconds(1), &frame), IsOk());
  EXPECT_THAT(source->Next(absl::Milliseconds(1), &frame),
              StatusIs(absl::StatusCode::kDeadlineExceeded, HasSubstr("no frame within")));
  EXPECT_EQ(frame.config.sequence, 0u);
}

TEST(SimulatorSource, CameraHasPlausibleIntrinsicsAndCapabilities) {
  auto source = OpenOrDie("sim:mirrors?pace=fast");
  const CameraInfo& camera = source->camera();
  EXPECT_EQ(camera.geometry, (ImageGeometry{163, 120}));
  EXPECT_GT(camera.intrinsics.fx, 100.0);
  EXPECT_EQ(camera.intrinsics.fx, camera.intrinsics.fy);
  EXPECT_DOUBLE_EQ(camera.intrinsics.cx, 81.0);
  EXPECT_DOUBLE_EQ(camera.intrinsics.cy, 59.5);
  EXPECT_THAT(camera.distortion, ::testing::Each(0.0));
  EXPECT_THAT(camera.model, HasSubstr("simulator"));
  const SourceCapabilities caps = source->capabilities();
  EXPECT_TRUE(caps.unmodulated_exposures);
  EXPECT_TRUE(caps.arbitrary_phase_shift);
  EXPECT_FALSE(caps.replay);
  EXPECT_EQ(source->uri(), "sim:mirrors?pace=fast");
}

// The simulated Kinect v2: its nine sub-frames, companded samples, dead columns, saturation.
TEST(SimulatorSource, TheKinect2CameraDeliversCompandedSubFramesWithDeadColumns) {
  auto source = OpenSource("sim:mirrors?camera=kinect2&width=32&height=16&pace=fast");
  ASSERT_THAT(source.status(), IsOk());
  ASSERT_THAT((*source)->Start(), IsOk());
  const std::array<int16_t, 2048>& table = kinect2::CompandingTable();
  const std::set<float> representable(table.begin(), table.end());
  std::multiset<int> harmonics;
  for (int s = 0; s < 9; ++s) {
    RawFrame frame;
    ASSERT_THAT((*source)->Next(absl::Seconds(5), &frame), IsOk());
    harmonics.insert(frame.config.harmonic);
    EXPECT_EQ(frame.saturation_level, 32767.0f);
    for (int y = 0; y < 16; ++y) {
      EXPECT_TRUE(std::isnan(frame.pixels[y * 32])) << y;
      EXPECT_TRUE(std::isnan(frame.pixels[y * 32 + 31])) << y;
      for (int x = 1; x < 31; ++x) {
        EXPECT_TRUE(representable.contains(frame.pixels[y * 32 + x])) << frame.pixels[y * 32 + x];
      }
    }
  }
  EXPECT_EQ(harmonics, (std::multiset<int>{2, 2, 2, 10, 10, 10, 15, 15, 15}));
  // Brighter than the full well: saturated samples, never a wrapped value.
  auto bright = OpenSource("sim:mirrors?camera=kinect2&width=32&height=16&pace=fast&brightness=1e10");
  ASSERT_THAT(bright.status(), IsOk());
  ASSERT_THAT((*bright)->Start(), IsOk());
  RawFrame frame;
  ASSERT_THAT((*bright)->Next(absl::Seconds(5), &frame), IsOk());
  EXPECT_EQ(frame.pixels[8 * 32 + 16], 32767.0f);
}

TEST(SimulatorSource, OpenSimulatorReportsItsCanonicalUri) {
  SimulatorOptions options;
  options.scene = "corner";
  options.schedule.order = 4;
  options.pace = Pace::kFast;
  auto source = OpenSimulator(options);
  ASSERT_THAT(source.status(), IsOk());
  EXPECT_EQ((*source)->uri(), "sim:corner?m=4&pace=fast");
}

// Per pixel, the returns with amplitude.
std::vector<int> ReturnCounts(const GroundTruth& truth) {
  const int64_t count = truth.geometry.pixel_count();
  std::vector<int> counts(count, 0);
  for (int r = 0; r < truth.max_returns; ++r) {
    for (int64_t p = 0; p < count; ++p)
      counts[p] += !std::isnan(truth.return_range_m[r * count + p]);
  }
  return counts;
}

TEST(GroundTruth, MirrorsHasThreeSeparableReturnsPerPixel) {
  // Pisarenko with m = 3 separates them with noise when they are at least 2 ns (0.3 m of range)
  // apart, also modulo the 23 MHz period (6.5 m of range).
  constexpr double kMinSeparation_m = 0.3;
  const double period_m = 0.5 * kSpeedOfLight / 23e6;
  auto source = OpenOrDie("sim:mirrors?pace=fast");
  const GroundTruth truth = *source->GroundTruthAt(0.0);
  ASSERT_EQ(truth.max_returns, 3);
  const int64_t count = truth.geometry.pixel_count();
  EXPECT_THAT(ReturnCounts(truth), ::testing::Each(3));
  double closest = INFINITY;
  for (int64_t p = 0; p < count; ++p) {
    for (int a = 0; a < 3; ++a) {
      for (int b = a + 1; b < 3; ++b) {
        const double d =
            std::abs(truth.return_range_m[b * count + p] - truth.return_range_m[a * count + p]);
        closest = std::min({closest, d, period_m - d});
      }
      EXPECT_GT(truth.return_amplitude[a * count + p], 0.0f);
      EXPECT_EQ(truth.return_spread_m[a * count + p], 0.0f);
    }
    EXPECT_LT(truth.return_range_m[count + p], truth.return_range_m[2 * count + p]) << "sorted";
    EXPECT_EQ(truth.first_range_m[p], truth.return_range_m[p]);
    EXPECT_NEAR(truth.first_range_m[p], 2.0, 0.6) << "the wall is 2 m away";
  }
  EXPECT_GT(closest, kMinSeparation_m);
}

TEST(GroundTruth, CalibrationIsADiracAtZeroWithAllMomentsEqual) {
  auto source = OpenOrDie("sim:calibration?pace=fast&width=32&height=24");
  const GroundTruth truth = *source->GroundTruthAt(0.0);
  ASSERT_EQ(truth.max_returns, 1);
  for (int64_t p = 0; p < truth.geometry.pixel_count(); ++p) {
    EXPECT_EQ(truth.first_range_m[p], 0.0f);
    const double c0 = TrueMoment(truth, 0, p).real();
    EXPECT_GT(c0, 0.0);
    for (int j = 1; j <= 3; ++j)
      EXPECT_NEAR(std::abs(TrueMoment(truth, j, p) - c0), 0.0, 1e-6 * c0);
  }
}

TEST(GroundTruth, CornerHasADirectDiracAndALaterContinuousReturn) {
  auto source = OpenOrDie("sim:corner?pace=fast");
  const GroundTruth truth = *source->GroundTruthAt(0.0);
  ASSERT_EQ(truth.max_returns, 2);
  const int64_t count = truth.geometry.pixel_count();
  int with_indirect = 0;
  for (int64_t p = 0; p < count; ++p) {
    ASSERT_FALSE(std::isnan(truth.first_range_m[p]));
    EXPECT_EQ(truth.return_spread_m[p], 0.0f);
    // The corner's edge is 2 m away, its visible walls nearer.
    EXPECT_GT(truth.first_range_m[p], 1.0);
    EXPECT_LT(truth.first_range_m[p], 2.2);
    if (std::isnan(truth.return_range_m[count + p])) continue;
    ++with_indirect;
    EXPECT_GE(truth.return_range_m[count + p], truth.return_range_m[p]);
    EXPECT_GT(truth.return_spread_m[count + p], 0.0f);
    EXPECT_LT(truth.return_amplitude[count + p], truth.return_amplitude[p]);
  }
  EXPECT_EQ(with_indirect, count);
  // Multipath: the magnitude of c_1 is less than c_0.
  EXPECT_LT(std::abs(TrueMoment(truth, 1, count / 2)),
            0.999 * TrueMoment(truth, 0, count / 2).real());
}

TEST(GroundTruth, SparseHasKReturnsPerPixelFromTheSeed) {
  auto a = OpenOrDie("sim:sparse?pace=fast&k=5&seed=3&width=16&height=12");
  auto b = OpenOrDie("sim:sparse?pace=fast&k=5&seed=4&width=16&height=12");
  const GroundTruth ta = *a->GroundTruthAt(0.0), tb = *b->GroundTruthAt(0.0);
  EXPECT_EQ(ta.max_returns, 5);
  EXPECT_THAT(ReturnCounts(ta), ::testing::Each(5));
  EXPECT_NE(ta.return_range_m, tb.return_range_m);
}

TEST(GroundTruth, VideoChangesWithTimeAndHoldsWithinACycle) {
  auto source = OpenOrDie("sim:video?pace=fast");
  const double cycle = 14 * source->camera().frame_period_s;
  const GroundTruth start = *source->GroundTruthAt(0.0);
  const GroundTruth within = *source->GroundTruthAt(0.5 * cycle);
  const GroundTruth later = *source->GroundTruthAt(1.5);
  EXPECT_EQ(start.first_range_m, within.first_range_m);
  int changed = 0;
  for (size_t p = 0; p < start.first_range_m.size(); ++p) {
    changed += std::abs(start.first_range_m[p] - later.first_range_m[p]) > 0.1f;
  }
  EXPECT_GT(changed, 100) << "the person moved";
  // The person (2 m) stands in front of the wall (3 m).
  const auto [nearest, farthest] =
      std::minmax_element(start.first_range_m.begin(), start.first_range_m.end());
  EXPECT_LT(*nearest, 2.2f);
  EXPECT_GT(*farthest, 3.0f);
  EXPECT_THAT(source->GroundTruthAt(-1.0).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("timestamp_s")));
}

TEST(GroundTruth, VideoFramesFollowTheScene) {
  auto source = OpenOrDie("sim:video?pace=fast&noise=none&width=48&height=32");
  ASSERT_THAT(source->Start(), IsOk());
  const std::vector<RawFrame> first = CaptureCycle(*source);
  for (int c = 0; c < 40; ++c) CaptureCycle(*source);
  const std::vector<RawFrame> later = CaptureCycle(*source);
  EXPECT_NE(first[3].pixels, later[3].pixels);
}

// Per pixel and harmonic, demodulated (ideal sinusoid, no noise) over true moments: the gain
// and delay errors of the camera, g_p * exp(i*2*pi*j*f*d_p).
std::vector<Complex> CameraErrors(absl::string_view scene, int camera_seed) {
  auto source = OpenOrDie(absl::StrCat("sim:", scene, "?camera_seed=", camera_seed,
                                       "&waveform=sinusoid&noise=none&adc_bits=0&", kSmallFast));
  EXPECT_THAT(source->Start(), IsOk());
  const auto moments = Demodulate(CaptureCycle(*source), source->schedule());
  const GroundTruth truth = *source->GroundTruthAt(0.0);
  std::vector<Complex> errors;
  for (int j = 1; j <= 3; ++j) {
    for (size_t p = 0; p < moments[j].size(); ++p) {
      errors.push_back(moments[j][p] / TrueMoment(truth, j, p));
    }
  }
  return errors;
}

TEST(FixedPattern, BelongsToTheCameraNotTheScene) {
  // The calibration scene's moments never vanish; the mirrors' could, so compare only where
  // the ratio is well conditioned.
  constexpr double kSame = 1e-4;
  const auto calibration = CameraErrors("calibration", 11);
  const auto mirrors = CameraErrors("mirrors", 11);
  const auto other_camera = CameraErrors("calibration", 12);
  double largest_difference = 0.0;
  for (size_t i = 0; i < calibration.size(); ++i) {
    EXPECT_NEAR(std::abs(calibration[i] - mirrors[i]), 0.0, kSame) << i;
    largest_difference = std::max(largest_difference, std::abs(calibration[i] - other_camera[i]));
  }
  EXPECT_GT(largest_difference, 0.05);
  // Not the identity: the default camera has gain and delay errors.
  EXPECT_GT(std::abs(calibration[0] - 1.0), 0.01);
}

}  // namespace
}  // namespace transient::sim::testing
