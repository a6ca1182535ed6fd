// The v4l2: source on emulated sensors (emulated_tof_sensor.h), through the real open, ioctl and
// mmap path: the mlx7502x profile's programming and read-back of the ToF controls, the stamps of
// every frame, the generic profile's alignment, and each fault with the counter it produces.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <linux/videodev2.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <numbers>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "tests/drivers/v4l2/emulated_tof_sensor.h"
#include "tests/drivers/v4l2/simulated_phases.h"
#include "tests/support/status_matchers.h"
#include "transient/drivers/capture_source.h"
#include "transient/drivers/source_registry.h"
#include "v4l2/frame_unpacker.h"
#include "v4l2/v4l2_device.h"

namespace transient::v4l2 {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;
using testing::EmulatedNode;
using testing::EmulatedTofSensor;
using testing::ProgrammedSequence;
using testing::SequenceFault;
using testing::SimulatedPhases;

constexpr ImageGeometry kSmall = {32, 24};
constexpr char kScene[] =
    "mirrors?gain_error=0&delay_error_ns=0&waveform=sinusoid&noise=none";
constexpr char kMlxUri[] =
    "v4l2:/dev/video0?profile=mlx7502x&width=32&height=24&f=20e6&m=3&exposure=500e-6"
    "&timeout_ms=300";

EmulatedNode Mlx75027(const testing::Renderer& renderer) {
  EmulatedNode node;
  node.formats = {{kFourccY12P, "12-bit Greyscale (MIPI Packed)"}, {kFourccY12, "12-bit Greyscale"}};
  node.controls = testing::Mlx7502xControls();
  node.sensor = kSmall;
  node.renderer = renderer;
  return node;
}

// Each frame a constant: 100 * (the sequence's index + 1) + its phase in degrees / 90, so that a
// test sees which frame went where.
std::vector<std::vector<int32_t>> Labelled(const ProgrammedSequence& sequence,
                                           ImageGeometry geometry) {
  std::vector<std::vector<int32_t>> frames;
  for (int64_t phase : sequence.phases_deg) {
    frames.emplace_back(static_cast<size_t>(geometry.pixel_count()),
                        static_cast<int32_t>(100 * (sequence.index + 1) + phase / 90));
  }
  return frames;
}

int64_t Counter(const CaptureSource& source, const std::string& name) {
  for (const SourceCounter& c : source.Counters()) {
    if (c.name == name) return c.value;
  }
  ADD_FAILURE() << "no counter " << name;
  return -1;
}

class V4l2SourceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(EmulatedTofSensor::Available())
        << "run under LD_PRELOAD=libumockdev-preload.so.0 (ctest does)";
  }

  std::unique_ptr<CaptureSource> OpenStarted(const std::string& uri) {
    absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource(uri);
    EXPECT_THAT(source.status(), IsOk());
    if (!source.ok()) return nullptr;
    EXPECT_THAT((*source)->Start(), IsOk());
    return *std::move(source);
  }

  // The next `n` frames; fails the test on an error.
  std::vector<RawFrame> Take(CaptureSource& source, int n) {
    std::vector<RawFrame> frames(static_cast<size_t>(n));
    for (RawFrame& frame : frames) {
      absl::Status status = source.Next(absl::Seconds(5), &frame);
      EXPECT_THAT(status, IsOk());
      if (!status.ok()) break;
    }
    return frames;
  }

  EmulatedTofSensor sensor_;
};

TEST_F(V4l2SourceTest, Mlx7502xSetsEverySequenceAndStampsTheReadBackValues) {
  EmulatedNode node = Mlx75027(Labelled);
  // The driver's integration step (re-ranged to the sensor's tint step, research §1.1): 8 us
  // from 5, so 500 us reads back as 501 us.
  node.controls[5].step = 8;
  sensor_.AddNode(node);
  std::unique_ptr<CaptureSource> source = OpenStarted(kMlxUri);
  ASSERT_NE(source, nullptr);
  EXPECT_EQ(source->schedule().raw_frames_per_frame(), 12);
  EXPECT_DOUBLE_EQ(source->schedule().options().exposure_s, 501e-6);
  EXPECT_EQ(source->camera().geometry.width, 32);
  // The open read every sequence back once; frames start with the first sequence after it.
  const int64_t before = sensor_.SequencesStarted("video0");
  const std::vector<RawFrame> frames = Take(*source, 24);
  for (size_t i = 0; i < frames.size(); ++i) {
    const ExposureConfig& c = frames[i].config;
    const int sequence = static_cast<int>(i / 4), phase = static_cast<int>(i % 4);
    EXPECT_EQ(c.cycle, sequence / 3) << i;
    EXPECT_EQ(c.harmonic, sequence % 3 + 1) << i;
    EXPECT_DOUBLE_EQ(c.frequency_hz, (sequence % 3 + 1) * 20e6) << i;
    EXPECT_NEAR(c.phase_shift_rad, phase * std::numbers::pi / 2, 1e-12) << i;
    EXPECT_DOUBLE_EQ(c.exposure_s, 501e-6) << "read back, not asked: " << i;
    EXPECT_THAT(source->schedule().IndexOf(c).status(), IsOk()) << i;
    // Signed 12-bit A - B: the labels come back as written.
    EXPECT_EQ(frames[i].pixels[7], 100 * (before + sequence + 1) + phase) << i;
    if (i > 0) {
      EXPECT_GT(c.timestamp_s, frames[i - 1].config.timestamp_s) << i;
      EXPECT_EQ(c.sequence, frames[i - 1].config.sequence + 1) << i;
    }
  }
  EXPECT_EQ(sensor_.Control("video0", kTofPhaseSequence.id),
            (std::vector<int64_t>{0, 90, 180, 270}));
  EXPECT_EQ(sensor_.Control("video0", kCameraTriggerMode.id), std::vector<int64_t>{1});
  EXPECT_EQ(Counter(*source, "sequences"), 6);
  EXPECT_EQ(Counter(*source, "buffers"), 24);
  EXPECT_EQ(Counter(*source, "discarded_buffers"), 0);
}

TEST_F(V4l2SourceTest, TheZerothMomentProxyIsASequenceAtTheSensorsLowestFrequency) {
  sensor_.AddNode(Mlx75027(Labelled));
  std::unique_ptr<CaptureSource> source = OpenStarted(absl::StrCat(kMlxUri, "&zeroth=proxy"));
  ASSERT_NE(source, nullptr);
  EXPECT_EQ(source->schedule().raw_frames_per_frame(), 16);
  EXPECT_DOUBLE_EQ(source->schedule().options().proxy_frequency_hz, 4e6) << "the control's minimum";
  const std::vector<RawFrame> frames = Take(*source, 16);
  for (size_t i = 0; i < frames.size(); ++i) {
    const ExposureConfig& c = frames[i].config;
    EXPECT_EQ(c.harmonic, static_cast<int>(i / 4)) << i;
    EXPECT_DOUBLE_EQ(c.frequency_hz, i < 4 ? 4e6 : static_cast<double>(i / 4) * 20e6) << i;
    EXPECT_THAT(source->schedule().IndexOf(c).status(), IsOk()) << i;
  }
}

// Each frame a constant: its integration time in microseconds, so that a sum of frames each
// scaled by (wanted time / set time) is the wanted total.
std::vector<std::vector<int32_t>> IntegrationValued(const ProgrammedSequence& sequence,
                                                    ImageGeometry geometry) {
  std::vector<std::vector<int32_t>> frames;
  for (size_t k = 0; k < sequence.phases_deg.size(); ++k) {
    frames.emplace_back(static_cast<size_t>(geometry.pixel_count()),
                        static_cast<int32_t>(sequence.integration_us[k]));
  }
  return frames;
}

TEST_F(V4l2SourceTest, HarmonicCancellationSumsSubExposuresAtTheirPhasesAndTimes) {
  sensor_.AddNode(Mlx75027(IntegrationValued));
  std::unique_ptr<CaptureSource> source =
      OpenStarted(absl::StrCat(kMlxUri, "&scheme=harmonic-cancellation&nphi=3"));
  ASSERT_NE(source, nullptr);
  const AcquisitionSchedule& schedule = source->schedule();
  EXPECT_EQ(schedule.options().sampling, SamplingScheme::kHarmonicCancellation);
  EXPECT_EQ(schedule.raw_frames_per_frame(), 12);  // the buckets; 36 buffers behind them
  const std::vector<RawFrame> frames = Take(*source, 12);
  for (size_t i = 0; i < frames.size(); ++i) {
    const ExposureConfig& c = frames[i].config;
    EXPECT_EQ(c.harmonic, static_cast<int>(i / 4) + 1) << i;
    EXPECT_NEAR(c.phase_shift_rad, static_cast<double>(i % 4) * std::numbers::pi / 2, 1e-12) << i;
    EXPECT_DOUBLE_EQ(c.exposure_s, 500e-6) << i;
    EXPECT_THAT(schedule.IndexOf(c).status(), IsOk()) << i;
    // Shares sin(45), sin(90), sin(135) of 500 us: 146.4, 207.1, 146.4 us, set as 146, 207,
    // 146 us; each frame scaled back to its share before the sum.
    EXPECT_NEAR(frames[i].pixels[5], 500.0f, 1e-3f) << i;
  }
  // Two sequences per harmonic (the phase control holds 8 phases: two buckets of three).
  EXPECT_EQ(sensor_.Control("video0", kTofPhaseSequence.id),
            (std::vector<int64_t>{180, 225, 270, 270, 315, 0}));
  EXPECT_EQ(sensor_.Control("video0", kTofTimeIntegration.id),
            (std::vector<int64_t>{146, 207, 146, 146, 207, 146}));
  EXPECT_EQ(Counter(*source, "sequences"), 6);
  EXPECT_EQ(Counter(*source, "buffers"), 36);
  // Steps of 180 / (nphi + 1) deg must be on the phase control's 45 deg grid.
  EXPECT_THAT(OpenSource(absl::StrCat(kMlxUri, "&scheme=harmonic-cancellation&nphi=2")).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("nphi = 2 needs phase steps of 60 deg"),
                             HasSubstr("steps of 45 deg"))));
  EXPECT_THAT(OpenSource("v4l2:/dev/video0?scheme=harmonic-cancellation").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("needs profile mlx7502x")));
  EXPECT_THAT(OpenSource("v4l2:/dev/video0?profile=mlx7502x&scheme=arccos").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("within one exposure")));
}

TEST_F(V4l2SourceTest, AFrequencyTheDriverRoundsAwayFromJTimesFIsAnError) {
  sensor_.AddNode(Mlx75027(Labelled));
  // 20.5 MHz: the driver sets whole MHz (step 1 MHz) and reads back 21 MHz for j = 1.
  absl::StatusOr<std::unique_ptr<CaptureSource>> source =
      OpenSource("v4l2:/dev/video0?profile=mlx7502x&width=32&height=24&f=20.5e6&m=2");
  EXPECT_THAT(source.status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("harmonic 1 needs 20500000 Hz"), HasSubstr("21000000"),
                             HasSubstr("not j*f"))));
}

TEST_F(V4l2SourceTest, ControlsUnderOtherIdsOnASubdeviceAreFoundByName) {
  EmulatedNode video = Mlx75027(Labelled);
  video.controls.clear();
  video.controls_on = "v4l-subdev0";
  EmulatedNode subdev;
  subdev.name = "v4l-subdev0";
  subdev.device_caps = 0;
  subdev.controls = testing::Mlx7502xControls(/*tof_base=*/0x00981ab0);  // a private range
  sensor_.AddNode(subdev);
  sensor_.AddNode(video);
  // Without the subdevice the video node has no ToF controls, and the message says what to do.
  EXPECT_THAT(OpenSource(kMlxUri).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("/dev/video0 has no control 'TOF Phase Sequence'"),
                             HasSubstr("subdev="))));
  std::unique_ptr<CaptureSource> source =
      OpenStarted(absl::StrCat(kMlxUri, "&subdev=/dev/v4l-subdev0"));
  ASSERT_NE(source, nullptr);
  const std::vector<RawFrame> frames = Take(*source, 12);
  EXPECT_DOUBLE_EQ(frames[11].config.frequency_hz, 60e6);
  EXPECT_EQ(sensor_.Control("v4l-subdev0", 0x00981ab1), std::vector<int64_t>{60'000'000});
}

TEST_F(V4l2SourceTest, VendorControlsAreSetByNameOrIdBeforeStreaming) {
  sensor_.AddNode(Mlx75027(Labelled));
  std::unique_ptr<CaptureSource> source =
      OpenStarted(absl::StrCat(kMlxUri, "&ctrl.output%20mode=2"));
  ASSERT_NE(source, nullptr);
  EXPECT_EQ(sensor_.Control("video0", 0x00981ad0), std::vector<int64_t>{2});
  source.reset();
  source = OpenStarted(absl::StrCat(kMlxUri, "&ctrl.0x00981ad0=3"));
  ASSERT_NE(source, nullptr);
  EXPECT_EQ(sensor_.Control("video0", 0x00981ad0), std::vector<int64_t>{3});
  // A menu value the driver does not have is refused, naming the control.
  EXPECT_THAT(OpenSource(absl::StrCat(kMlxUri, "&ctrl.0x00981ad0=9")).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("'Output Mode' = 9")));
}

TEST_F(V4l2SourceTest, TheDaemonCanChangeTheTakesInTheUri) {
  absl::StatusOr<std::string> uri = SourceUriWithTakes(kMlxUri, 4);
  ASSERT_THAT(uri.status(), IsOk());
  EXPECT_EQ(*uri, absl::StrCat(kMlxUri, "&takes=4"));
  absl::StatusOr<std::string> again = SourceUriWithTakes(*uri, 2);
  ASSERT_THAT(again.status(), IsOk());
  EXPECT_EQ(*again, absl::StrCat(kMlxUri, "&takes=2"));
  EXPECT_THAT(SourceUriWithTakes(kMlxUri, 0).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("takes = '0'")));
}

TEST_F(V4l2SourceTest, ARefusedControlIsNamedWithItsValue) {
  EmulatedNode node = Mlx75027(Labelled);
  node.refuse_control = kTofFrequencyModulation.id;
  sensor_.AddNode(node);
  EXPECT_THAT(OpenSource(kMlxUri).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("'TOF Frequency Modulation' = 20000000"),
                             HasSubstr("refused"))));
}

TEST_F(V4l2SourceTest, BadUrisSayWhichKeyIsWrong) {
  sensor_.AddNode(Mlx75027(Labelled));
  const struct {
    const char* uri;
    const char* message;
  } cases[] = {
      {"v4l2:", "no device"},
      {"v4l2:/dev/video0?profile=kinect", "profile = 'kinect'; expected generic or mlx7502x"},
      {"v4l2:/dev/video0?zeroth=pair", "zeroth = pair needs the emitter switched off"},
      {"v4l2:/dev/video0?phases=0,45,90,135", "phases = '0,45,90,135'"},
      {"v4l2:/dev/video0?profile=mlx7502x&align=gap", "needs align=trigger"},
      {"v4l2:/dev/video0?fmt=MJPG", "fmt = 'MJPG'"},
      {"v4l2:/dev/video0?bits=20", "bits = '20'"},
      {"v4l2:/dev/video0?speed=2", "unknown key 'speed'"},
      {"v4l2:/dev/video0?width=64&height=24", "asked for Y12 64x24, the driver granted Y12 32x24"},
      {"v4l2:/dev/video0?profile=mlx7502x&ctrl.Gain=3", "ctrl.Gain: no such control"},
  };
  for (const auto& c : cases) {
    EXPECT_THAT(OpenSource(c.uri).status(),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(c.message)))
        << c.uri;
  }
  EXPECT_THAT(OpenSource("v4l2:/dev/video7").status(), StatusIs(absl::StatusCode::kNotFound, HasSubstr("/dev/video7")));
}

// The generic profile: the sensor runs its own program (continuous mode, set up by another
// tool) and the URI says what it is.
void ExpectGenericAlignment(EmulatedTofSensor& sensor, const std::string& align) {
  EmulatedNode node = Mlx75027(Labelled);
  node.formats = {{kFourccY12, "12-bit Greyscale"}};
  sensor.AddNode(node);
  sensor.SetControl("video0", kTofPhaseSequence.id, {0, 90, 180, 270});
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource(absl::StrCat(
      "v4l2:/dev/video0?width=32&height=24&f=40e6&m=1&align=", align, "&gap_ms=10"));
  ASSERT_THAT(source.status(), IsOk());
  ASSERT_THAT((*source)->Start(), IsOk());
  std::vector<RawFrame> frames(8);
  for (RawFrame& frame : frames) ASSERT_THAT((*source)->Next(absl::Seconds(5), &frame), IsOk());
  for (size_t i = 0; i < frames.size(); ++i) {
    const int phase = static_cast<int>(i % 4);
    EXPECT_NEAR(frames[i].config.phase_shift_rad, phase * std::numbers::pi / 2, 1e-12);
    EXPECT_DOUBLE_EQ(frames[i].config.frequency_hz, 40e6) << "from the URI";
    // Each frame is the sensor's frame of that phase: the label's last digit.
    EXPECT_EQ(static_cast<int>(frames[i].pixels[0]) % 100, phase) << i;
  }
  EXPECT_EQ(frames[4].pixels[0] - frames[0].pixels[0], 100) << "consecutive sequences";
  EXPECT_EQ(frames[7].config.cycle, 1);
}

TEST_F(V4l2SourceTest, GenericProfileAlignsByTheDriversSequenceNumbers) {
  ExpectGenericAlignment(sensor_, "sequence");
}

TEST_F(V4l2SourceTest, GenericProfileAlignsByThePauseBetweenSequences) {
  ExpectGenericAlignment(sensor_, "gap");
}

TEST_F(V4l2SourceTest, GenericProfileCanTriggerEachCycleWhereTheSensorHasATrigger) {
  sensor_.AddNode(Mlx75027(Labelled));
  sensor_.SetControl("video0", kTofPhaseSequence.id, {0, 90, 180, 270});
  std::unique_ptr<CaptureSource> source =
      OpenStarted("v4l2:/dev/video0?fmt=Y12&width=32&height=24&f=40e6&m=1&align=trigger");
  ASSERT_NE(source, nullptr);
  EXPECT_EQ(sensor_.Control("video0", kCameraTriggerMode.id), std::vector<int64_t>{1});
  const std::vector<RawFrame> frames = Take(*source, 8);
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(static_cast<int>(frames[i].pixels[0]), 100 * static_cast<int>(i / 4 + 1) +
                                                         static_cast<int>(i % 4))
        << i;
  }
  EXPECT_EQ(sensor_.Control("video0", kTofFrequencyModulation.id), std::vector<int64_t>{40'000'000})
      << "the generic profile sets no ToF control (40 MHz is the driver's default)";
  // A node without a trigger cannot be triggered: the message says what is missing.
  EmulatedNode plain = Mlx75027(Labelled);
  plain.name = "video1";
  plain.controls.clear();
  sensor_.AddNode(plain);
  EXPECT_THAT(OpenSource("v4l2:/dev/video1?fmt=Y12&width=32&height=24&m=1&align=trigger").status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("has no control 'Camera Trigger'"),
                             HasSubstr("no controls at all"))));
}

TEST_F(V4l2SourceTest, SuperframesCarryAllPhasesInOneBuffer) {
  EmulatedNode node = Mlx75027(nullptr);
  node.formats = {{kFourccY16, "16-bit Greyscale"}};
  node.sensor = {8, 4 * 6};  // four 8 x 6 phase images stacked
  sensor_.AddNode(node);
  for (int s = 0; s < 2; ++s) {
    std::vector<int32_t> samples;
    for (int phase = 0; phase < 4; ++phase) samples.insert(samples.end(), 8 * 6, 1000 * s + phase);
    sensor_.PushFrame("video0", {.bytes = testing::PackSamples(kFourccY16, node.sensor, 16, 16, samples),
                                 .timestamp_ns = 1'000'000'000 + s * 50'000'000});
  }
  std::unique_ptr<CaptureSource> source = OpenStarted(
      "v4l2:/dev/video0?fmt=Y16&width=8&height=6&subframes=4&m=1&f=30e6");
  ASSERT_NE(source, nullptr);
  const std::vector<RawFrame> frames = Take(*source, 8);
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].geometry.height, 6);
    EXPECT_EQ(frames[i].pixels[47], 1000 * static_cast<int>(i / 4) + static_cast<int>(i % 4)) << i;
    EXPECT_NEAR(frames[i].config.phase_shift_rad, static_cast<double>(i % 4) * std::numbers::pi / 2,
                1e-12);
  }
}

struct FaultCase {
  SequenceFault::Kind kind;
  int frame;  // of the sequence's four
  const char* counter;
  bool events = true;  // the driver sends control events (else the read-back must catch it)
};

class V4l2SourceFaultTest : public V4l2SourceTest,
                            public ::testing::WithParamInterface<FaultCase> {};

// The sequence with the fault is dropped whole and taken again: the frames that come are all of
// whole sequences, each exactly once per cycle, and the counter says what happened.
TEST_P(V4l2SourceFaultTest, TheBrokenSequenceIsDroppedCountedAndTakenAgain) {
  EmulatedNode node = Mlx75027(Labelled);
  node.events = GetParam().events;
  sensor_.AddNode(node);
  std::unique_ptr<CaptureSource> source = OpenStarted(kMlxUri);
  ASSERT_NE(source, nullptr);
  const int64_t first = sensor_.SequencesStarted("video0");
  // The second sequence of the stream (harmonic 2 of cycle 0) goes wrong at its third frame.
  sensor_.InjectFault("video0", {.sequence = first + 1, .kind = GetParam().kind,
                                 .frame = GetParam().frame, .value = 77'000'000});
  const std::vector<RawFrame> frames = Take(*source, 24);
  for (size_t i = 0; i < frames.size(); ++i) {
    const ExposureConfig& c = frames[i].config;
    EXPECT_EQ(c.harmonic, static_cast<int>(i / 4) % 3 + 1) << i;
    EXPECT_EQ(c.cycle, static_cast<int>(i / 12)) << i;
    // Whole sequences of one trigger each: all four frames carry the same sequence label.
    const int label = static_cast<int>(frames[i].pixels[0]);
    EXPECT_EQ(label % 100, static_cast<int>(i % 4)) << i;
    EXPECT_EQ(label / 100, static_cast<int>(frames[i - i % 4].pixels[0]) / 100) << i;
  }
  // Harmonic 2 of cycle 0 is the retake, not the broken sequence.
  EXPECT_EQ(static_cast<int>(frames[4].pixels[0]) / 100, first + 3);
  EXPECT_EQ(Counter(*source, GetParam().counter), 1);
  EXPECT_EQ(Counter(*source, "sequences"), 6);
  if (GetParam().kind == SequenceFault::kStall) {
    EXPECT_EQ(Counter(*source, "restarts"), 1);
  }
  if (GetParam().kind == SequenceFault::kLostFrame) {
    // Lost inside the sequence, the next frame's number shows it; lost last, only the
    // watchdog does (the sequence is abandoned and taken again without a restart).
    EXPECT_EQ(Counter(*source, "restarts"), 0);
    EXPECT_EQ(Counter(*source, "driver_frames_lost"), 1);
  }
  if (GetParam().kind == SequenceFault::kControlChanged) {
    // Noticed at once by its event (abandoned, not a whole sequence), or by the read-back at
    // its end (whole, then dropped); set again before the retake either way.
    EXPECT_EQ(Counter(*source, "sequences_dropped_abandoned"), 0);
    EXPECT_EQ(sensor_.Control("video0", kTofFrequencyModulation.id),
              std::vector<int64_t>{60'000'000});
  }
}

INSTANTIATE_TEST_SUITE_P(
    Faults, V4l2SourceFaultTest,
    ::testing::Values(FaultCase{SequenceFault::kErrorFlag, 2, "sequences_dropped_error_flag"},
                      FaultCase{SequenceFault::kShortFrame, 2, "sequences_dropped_wrong_size"},
                      FaultCase{SequenceFault::kLostFrame, 2, "sequences_dropped_sequence_gap"},
                      FaultCase{SequenceFault::kLostFrame, 3, "sequences_dropped_abandoned"},
                      FaultCase{SequenceFault::kStall, 0, "watchdog_timeouts"},
                      FaultCase{SequenceFault::kControlChanged, 2,
                                "sequences_dropped_control_changed"},
                      FaultCase{SequenceFault::kControlChanged, 2,
                                "sequences_dropped_control_changed", /*events=*/false}),
    [](const ::testing::TestParamInfo<FaultCase>& info) {
      std::string name = absl::StrCat(info.param.counter, info.param.events ? "" : "_readback");
      name.erase(std::remove(name.begin(), name.end(), '_'), name.end());
      return name;
    });

TEST_F(V4l2SourceTest, AStallThatOutlastsTheRestartsIsUnavailable) {
  sensor_.AddNode(Mlx75027(Labelled));
  std::unique_ptr<CaptureSource> source = OpenStarted(
      "v4l2:/dev/video0?profile=mlx7502x&width=32&height=24&m=1&timeout_ms=100&restart=2");
  ASSERT_NE(source, nullptr);
  const int64_t first = sensor_.SequencesStarted("video0");
  for (int s = 0; s < 3; ++s) {
    sensor_.InjectFault("video0", {.sequence = first + s, .kind = SequenceFault::kStall});
  }
  RawFrame frame;
  absl::Status status;
  const absl::Time give_up = absl::Now() + absl::Seconds(10);
  do {
    status = source->Next(absl::Milliseconds(100), &frame);
  } while (absl::IsDeadlineExceeded(status) && absl::Now() < give_up);
  EXPECT_THAT(status, StatusIs(absl::StatusCode::kUnavailable,
                               HasSubstr("no whole sequence after 2 stream restarts")));
  EXPECT_EQ(Counter(*source, "restarts"), 3);
  EXPECT_EQ(Counter(*source, "watchdog_timeouts"), 3);
}

TEST_F(V4l2SourceTest, UnplugIsUnavailableAndTheRepluggedSensorOpensAgain) {
  sensor_.AddNode(Mlx75027(Labelled));
  std::unique_ptr<CaptureSource> source = OpenStarted(kMlxUri);
  ASSERT_NE(source, nullptr);
  sensor_.InjectFault("video0",
                      {.sequence = sensor_.SequencesStarted("video0") + 1,
                       .kind = SequenceFault::kUnplug});
  RawFrame frame;
  absl::Status status;
  for (int i = 0; i < 10 && status.ok(); ++i) status = source->Next(absl::Seconds(5), &frame);
  EXPECT_THAT(status, StatusIs(absl::StatusCode::kUnavailable, HasSubstr("device gone")));
  source.reset();
  EXPECT_THAT(OpenSource(kMlxUri).status(),
              StatusIs(absl::StatusCode::kUnavailable, HasSubstr("device gone")));
  sensor_.Replug("video0");
  source = OpenStarted(kMlxUri);
  ASSERT_NE(source, nullptr);
  EXPECT_EQ(Take(*source, 4)[3].config.harmonic, 1);
}

// The simulator's light through the whole path: the phasor of every harmonic from the
// emulated sensor's frames is the one the same scene gives through sim: at that frequency.
TEST_F(V4l2SourceTest, RenderedFramesCarryTheScenesCorrelation) {
  SimulatedPhases light(kScene, /*signed_output=*/true);
  sensor_.AddNode(Mlx75027(light.AsRenderer()));
  std::unique_ptr<CaptureSource> source = OpenStarted(kMlxUri);
  ASSERT_NE(source, nullptr);
  const std::vector<RawFrame> frames = Take(*source, 4);
  absl::StatusOr<std::unique_ptr<CaptureSource>> sim =
      OpenSource(light.CameraUri(20e6, 500e-6, kSmall));
  ASSERT_THAT(sim.status(), IsOk());
  ASSERT_THAT((*sim)->Start(), IsOk());
  for (int k = 0; k < 4; ++k) {
    RawFrame expected;
    ASSERT_THAT((*sim)->Next(absl::Seconds(5), &expected), IsOk());
    for (size_t p = 0; p < expected.pixels.size(); p += 37) {
      EXPECT_EQ(frames[static_cast<size_t>(k)].pixels[p], expected.pixels[p] - 2048.0f) << k;
    }
  }
}

// Against a real node, on a machine that has one (for example `modprobe vivid`, which streams
// Y12 and Y16): TRANSIENT_TEST_V4L2_DEVICE=/dev/videoN, and optionally TRANSIENT_TEST_V4L2_URI
// for the source to open (default: the generic profile, m = 1, Y16 at 640 x 480). Skipped, with
// this message, where unset: no machine of the project's CI has V4L2 hardware or modules.
TEST(V4l2RealDevice, OpensTheNodeAndTakesOneCycle) {
  const char* device = std::getenv("TRANSIENT_TEST_V4L2_DEVICE");
  if (device == nullptr || *device == '\0') {
    GTEST_SKIP() << "set TRANSIENT_TEST_V4L2_DEVICE=/dev/videoN to test a real node";
  }
  absl::StatusOr<V4l2Device> node = V4l2Device::Open(device);
  ASSERT_THAT(node.status(), IsOk());
  absl::StatusOr<Capabilities> caps = node->QueryCapabilities();
  ASSERT_THAT(caps.status(), IsOk());
  EXPECT_TRUE(caps->capture() && caps->streaming()) << caps->card;
  const char* uri = std::getenv("TRANSIENT_TEST_V4L2_URI");
  const std::string source_uri =
      uri != nullptr && *uri != '\0' ? std::string(uri)
                                     : absl::StrCat("v4l2:", device, "?fmt=Y16&m=1&f=20e6");
  node = absl::UnavailableError("closed");  // the source opens the node itself
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource(source_uri);
  ASSERT_THAT(source.status(), IsOk());
  ASSERT_THAT((*source)->Start(), IsOk());
  const int frames = (*source)->schedule().raw_frames_per_frame();
  RawFrame frame;
  for (int i = 0; i < frames; ++i) {
    ASSERT_THAT((*source)->Next(absl::Seconds(5), &frame), IsOk()) << i;
    EXPECT_EQ(frame.pixels.size(),
              static_cast<size_t>((*source)->camera().geometry.pixel_count()));
  }
  EXPECT_THAT((*source)->Stop(), IsOk());
}

}  // namespace
}  // namespace transient::v4l2
