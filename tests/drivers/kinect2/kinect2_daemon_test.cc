// transientd and `transient record` on usb:kinect2, the emulated Kinect v2 showing the simulated
// Kinect v2's corner (simulated_kinect2.h) through Debian's real libusb: depth against the
// scene's truth as close as the same simulated frames give through sim:'s path, the transient products refused naming the missing
// harmonics, the source's counters in GetStats, and a recording that replays to the live
// camera's raw frames and calibration. A real daemon in this process, real gRPC on loopback.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "tests/drivers/kinect2/emulated_kinect2.h"
#include "tests/drivers/kinect2/simulated_kinect2.h"
#include "tests/service/daemon_fixture.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "tools/transient/commands/record_command.h"
#include "transient/drivers/calibration_capture.h"
#include "transient/drivers/capture_source.h"
#include "transient/reconstruct/frame_pipeline.h"
#include "transient/reconstruct/frame_products.h"
#include "transient/reconstruct/percentile.h"

namespace transient::kinect2 {
namespace {

using ::testing::HasSubstr;
using ::transient::service::PipelineOptions;
using ::transient::service::testing::Daemon;
using ::transient::service::testing::FirstDecodedFrame;
using ::transient::service::testing::Request;
using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;
namespace emu = ::transient::kinect2::testing;

constexpr char kScene[] = "sim:corner?camera=kinect2&pace=fast";

class Kinect2DaemonTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(emu::EmulatedKinect2::Available())
        << "run under LD_PRELOAD=libumockdev-preload.so.0 (ctest does)";
  }
  // The emulated camera showing `scene` (a sim: URI with camera=kinect2).
  void Emulate(const std::string& scene) {
    scene_ = std::make_unique<emu::SimulatedKinect2>(scene);
    ASSERT_TRUE(scene_->ok());
    emu::Options options;
    options.renderer = scene_->AsRenderer();
    options.p0_tables = scene_->P0Tables();
    absl::StatusOr<std::unique_ptr<emu::EmulatedKinect2>> camera =
        emu::EmulatedKinect2::Create(std::move(options));
    ASSERT_THAT(camera.status(), IsOk());
    camera_ = *std::move(camera);
  }

  std::unique_ptr<emu::SimulatedKinect2> scene_;
  std::unique_ptr<emu::EmulatedKinect2> camera_;
};

// A scene whose size is not the camera's (width= after camera=kinect2 changes the preset) is
// refused: its sub-frames would not fill the emulator's 512 x 424 samples.
TEST(SimulatedKinect2, ASceneOfAnotherSizeThanTheCamerasIsNotOk) {
  const std::string narrow = absl::StrCat(kScene, "&width=256");
  ASSERT_THAT(OpenSource(narrow).status(), IsOk()) << "the scene itself is valid";
  EXPECT_FALSE(emu::SimulatedKinect2(narrow).ok());
}

// Median |range - first return| over the pixels with both.
double MedianRangeError(const std::vector<float>& range, const std::vector<float>& truth) {
  std::vector<double> errors;
  for (size_t p = 0; p < range.size(); ++p) {
    if (std::isfinite(range[p]) && std::isfinite(truth[p])) {
      errors.push_back(std::abs(range[p] - truth[p]));
    }
  }
  return errors.size() < range.size() / 2 ? INFINITY : Percentile(errors, 50.0);
}

TEST_F(Kinect2DaemonTest, ServesDepthAsCloseToTheTruthAsTheSimulatorAndRefusesTransientVideo) {
  ASSERT_NO_FATAL_FAILURE(Emulate(kScene));
  absl::StatusOr<std::unique_ptr<CaptureSource>> sim = OpenSource(kScene);
  ASSERT_THAT(sim.status(), IsOk());
  absl::StatusOr<GroundTruth> truth = (*sim)->GroundTruthAt(0.0);
  ASSERT_THAT(truth.status(), IsOk());

  double usb_error = INFINITY, sim_error = INFINITY;
  {
    // transientd's choice for a source that carries its calibration: the camera's P0 tables.
    PipelineOptions options{.source_uri = "usb:kinect2"};
    {
      absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource("usb:kinect2");
      ASSERT_THAT(source.status(), IsOk());
      const CalibrationTable* table = (*source)->embedded_calibration(nullptr);
      ASSERT_NE(table, nullptr);
      options.calibration = *table;
    }
    Daemon daemon(options);
    absl::StatusOr<std::map<std::string, std::vector<float>>> images = FirstDecodedFrame(
        daemon, Request({v1::RANGE, v1::DEPTH, v1::AMPLITUDE, v1::CONFIDENCE, v1::FLAGS}));
    ASSERT_THAT(images.status(), IsOk());
    usb_error = MedianRangeError((*images)["range"], truth->first_range_m);
    EXPECT_EQ(images->size(), 5u);

    absl::StatusOr<std::map<std::string, std::vector<float>>> refused =
        FirstDecodedFrame(daemon, Request({v1::SLICES}));
    EXPECT_EQ(refused.status().code(), absl::StatusCode::kFailedPrecondition);
    EXPECT_THAT(refused.status().message(), HasSubstr("missing 1, 3-9, 11-14"));

    std::map<std::string, int64_t> counters;
    const v1::Stats stats = daemon.Stats();
    for (const v1::SourceCounter& c : stats.source_counters()) counters[c.name()] = c.value();
    EXPECT_GT(counters["frames"], 0);
    EXPECT_EQ(counters["iso_packet_errors"], 0);
  }
  {
    // The same frames through sim:'s path: the simulator's raw frames of the cycle the camera
    // shows, measured with a calibration against the simulated camera's Dirac at zero, then
    // unwrapped as the daemon does.
    absl::StatusOr<std::unique_ptr<CaptureSource>> calibration =
        OpenSource("sim:calibration?camera=kinect2&pace=fast");
    ASSERT_THAT(calibration.status(), IsOk());
    absl::StatusOr<CalibrationCapture> measured = CaptureCalibration(**calibration, 4);
    ASSERT_THAT(measured.status(), IsOk());
    absl::StatusOr<FramePipeline> pipeline = FramePipeline::Create(
        scene_->schedule(), ImageGeometry{512, 424},
        MeasureOptions{.calibration =
                           std::make_shared<const CalibrationTable>(std::move(measured->table))},
        SolveOptions{});
    ASSERT_THAT(pipeline.status(), IsOk());
    MomentImage moments;
    ASSERT_THAT(pipeline->Measure(scene_->frames(), &moments), IsOk());
    const ScheduleOptions& schedule = scene_->schedule().options();
    std::shared_ptr<const FrameProducts> products = ComputeUnwrappedProducts(
        moments, CameraInfo{},
        UnwrapOptions{.base_frequency_hz = schedule.base_frequency_hz,
                      .harmonics = schedule.MeasuredHarmonics()},
        ProductNeeds{.range = true});
    sim_error = MedianRangeError(products->range_m, truth->first_range_m);
  }
  // Measured: see docs/kinect2.md. The P0 tables undo the simulated camera's delays like the
  // calibration scene does; the 11-bit companding of the emulated camera is the simulator's.
  EXPECT_LT(sim_error, 0.04);
  EXPECT_LT(usb_error, 0.04) << "through sim: " << sim_error << " m";
  EXPECT_LT(usb_error, sim_error + 0.005);
  RecordProperty("usb_median_range_error_m", absl::StrCat(usb_error));
  RecordProperty("sim_median_range_error_m", absl::StrCat(sim_error));
}

bool SameSamples(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

TEST_F(Kinect2DaemonTest, ARecordingReplaysToTheLiveCamerasFramesAndCalibration) {
  // Any picture will do; the mirrors' Dirac returns render faster than the corner's.
  ASSERT_NO_FATAL_FAILURE(Emulate("sim:mirrors?camera=kinect2&pace=fast"));
  ScratchDirectory scratch;
  const std::string path = scratch.File("kinect2.h5");
  absl::StatusOr<tools::RecordSummary> recorded =
      tools::RunRecord({.source_uri = "usb:kinect2", .output_path = path, .frames = 2});
  ASSERT_THAT(recorded.status(), IsOk());
  EXPECT_EQ(recorded->cycles, 2);
  EXPECT_TRUE(recorded->embedded_calibration);

  absl::StatusOr<std::unique_ptr<CaptureSource>> replay =
      OpenSource(absl::StrCat("replay:", path, "?pace=fast"));
  ASSERT_THAT(replay.status(), IsOk());
  absl::StatusOr<std::unique_ptr<CaptureSource>> live = OpenSource("usb:kinect2");
  ASSERT_THAT(live.status(), IsOk());
  EXPECT_EQ((*replay)->schedule().Describe(), (*live)->schedule().Describe());
  const CalibrationTable* replayed = (*replay)->embedded_calibration(nullptr);
  const CalibrationTable* factory = (*live)->embedded_calibration(nullptr);
  ASSERT_NE(replayed, nullptr);
  ASSERT_NE(factory, nullptr);
  EXPECT_TRUE(SameSamples(replayed->real, factory->real));
  EXPECT_TRUE(SameSamples(replayed->imag, factory->imag));
  EXPECT_EQ((*replay)->camera().intrinsics.fx, (*live)->camera().intrinsics.fx);

  ASSERT_THAT((*replay)->Start(), IsOk());
  ASSERT_THAT((*live)->Start(), IsOk());
  // The scene holds still, so every frame has the same samples; a frame the recorder was too
  // slow for is dropped (counted) by the source, so both are checked against the stamping rule
  // rather than frame by frame: sub-frame k of cycle n at n * 33.25 ms + k * 3.25 ms.
  auto check_stamp = [](const RawFrame& f, int k) {
    EXPECT_EQ(f.config.sequence, static_cast<uint64_t>(f.config.cycle * 10 + k));
    EXPECT_NEAR(f.config.timestamp_s, (266.0 * f.config.cycle + 26.0 * k) * 125e-6, 1e-9);
  };
  int replayed_frames = 0;
  for (int i = 0; i < 18; ++i) {
    RawFrame a, b;
    const absl::Status status = (*replay)->Next(absl::Seconds(10), &a);
    if (absl::IsOutOfRange(status)) break;
    ASSERT_THAT(status, IsOk());
    ASSERT_THAT((*live)->Next(absl::Seconds(10), &b), IsOk());
    ++replayed_frames;
    const int k = i % 9;
    EXPECT_EQ(a.config.harmonic, b.config.harmonic) << i;
    EXPECT_EQ(a.config.phase_shift_rad, b.config.phase_shift_rad) << i;
    check_stamp(a, k);
    check_stamp(b, k);
    EXPECT_EQ(a.saturation_level, b.saturation_level);
    EXPECT_TRUE(SameSamples(a.pixels, b.pixels)) << i;  // NaN dead columns included
  }
  EXPECT_EQ(replayed_frames, 18);
}

}  // namespace
}  // namespace transient::kinect2
