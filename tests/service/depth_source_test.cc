// transientd on a source that delivers depth instead of modulated captures (SamplingScheme::kDepth,
// as an OpenNI2 device or .oni file does): DEPTH as given, RANGE along the pixels' rays,
// AMPLITUDE, FLAGS where there is no depth and MOMENT_DEPTH of the depth; everything that needs
// modulated captures refused with FAILED_PRECONDITION saying so. A real daemon in this process,
// real gRPC on loopback, fed by a test source handed in through PipelineOptions::open_source.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "tests/service/daemon_fixture.h"
#include "tests/support/status_matchers.h"
#include "transient/drivers/capture_source.h"
#include "transient/reconstruct/calibration.h"

namespace transient::service {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::transient::service::testing::Daemon;
using ::transient::service::testing::FirstDecodedFrame;
using ::transient::service::testing::FirstFrame;
using ::transient::service::testing::Request;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

constexpr ImageGeometry kGeometry{.width = 16, .height = 12};
constexpr double kMaxDepthM = 6.0;
constexpr char kUri[] = "test:depth";
constexpr char kRefused[] = "the source delivers depth, not modulated captures: ";
// float32 on the wire is exact; range is Z divided by a ray factor in double, then rounded to
// float on both sides: a couple of float ulps.
constexpr double kFloatRelative = 3e-7;

// The known depth of pixel p, metres: a ramp from 1 m, with no depth (NaN, 0 or negative, as
// depth cameras say it) at every 7th, 11th and 13th pixel.
float PatternDepth(int64_t p) {
  if (p % 7 == 0) return std::numeric_limits<float>::quiet_NaN();
  if (p % 11 == 0) return 0.0f;
  if (p % 13 == 0) return -1.0f;
  return 1.0f + 0.0173f * static_cast<float>(p);
}
bool HasDepth(int64_t p) { return p % 7 != 0 && p % 11 != 0 && p % 13 != 0; }
float PatternAmplitude(int64_t p) { return 200.0f + static_cast<float>(p % 50); }

// A test source, not a driver: a depth camera delivering PatternDepth (Z, metres) and, when
// asked, PatternAmplitude in every cycle, one frame every millisecond.
class TestDepthSource final : public CaptureSource {
 public:
  explicit TestDepthSource(bool amplitude) : uri_(kUri) {
    camera_.geometry = kGeometry;
    camera_.intrinsics = {.fx = 14.0, .fy = 15.0, .cx = 7.5, .cy = 5.5};
    camera_.model = "test depth camera";
    ScheduleOptions options;
    options.sampling = SamplingScheme::kDepth;
    options.max_depth_m = kMaxDepthM;
    options.depth_amplitude = amplitude;
    absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(options);
    EXPECT_THAT(schedule.status(), IsOk());
    schedule_ = *std::move(schedule);
  }

  const std::string& uri() const override { return uri_; }
  const CameraInfo& camera() const override { return camera_; }
  const AcquisitionSchedule& schedule() const override { return schedule_; }
  SourceCapabilities capabilities() const override { return {}; }
  absl::Status Start() override {
    started_ = true;
    return absl::OkStatus();
  }
  absl::Status Stop() override {
    started_ = false;
    return absl::OkStatus();
  }
  absl::Status Next(absl::Duration, RawFrame* frame) override {
    if (!started_) return absl::FailedPreconditionError("not started");
    absl::SleepFor(absl::Milliseconds(1));
    const int per_cycle = schedule_.raw_frames_per_frame();
    const int index = static_cast<int>(sequence_ % static_cast<uint64_t>(per_cycle));
    frame->config = schedule_.exposures()[static_cast<size_t>(index)];
    frame->config.cycle = static_cast<int64_t>(sequence_ / static_cast<uint64_t>(per_cycle));
    frame->config.sequence = sequence_;
    frame->config.timestamp_s = 1e-3 * static_cast<double>(sequence_);
    frame->geometry = kGeometry;
    frame->pixels.resize(static_cast<size_t>(kGeometry.pixel_count()));
    const bool depth = frame->config.content == FrameContent::kDepth;
    for (int64_t p = 0; p < kGeometry.pixel_count(); ++p) {
      frame->pixels[static_cast<size_t>(p)] = depth ? PatternDepth(p) : PatternAmplitude(p);
    }
    ++sequence_;
    return absl::OkStatus();
  }

 private:
  std::string uri_;
  CameraInfo camera_;
  AcquisitionSchedule schedule_ = *AcquisitionSchedule::Create({});
  bool started_ = false;
  uint64_t sequence_ = 0;
};

PipelineOptions DepthCamera(bool amplitude) {
  PipelineOptions options;
  options.source_uri = kUri;
  // The test seam of the daemon: a source object instead of a registered URI scheme.
  options.open_source =
      [amplitude](const std::string&) -> absl::StatusOr<std::unique_ptr<CaptureSource>> {
    return std::make_unique<TestDepthSource>(amplitude);
  };
  return options;
}

TEST(DepthSourceDaemon, ServesTheGivenDepthItsRangeAmplitudeFlagsAndMomentDepth) {
  Daemon daemon(DepthCamera(/*amplitude=*/true));
  absl::StatusOr<std::map<std::string, std::vector<float>>> images = FirstDecodedFrame(
      daemon, Request({v1::DEPTH, v1::RANGE, v1::AMPLITUDE, v1::FLAGS, v1::MOMENT_DEPTH}));
  ASSERT_THAT(images.status(), IsOk());
  const std::vector<float>& depth = (*images)["depth"];
  const std::vector<float>& range = (*images)["range"];
  const std::vector<float>& amplitude = (*images)["amplitude"];
  const std::vector<float>& flags = (*images)["flags"];
  const size_t n = static_cast<size_t>(kGeometry.pixel_count());
  ASSERT_EQ(depth.size(), n);
  ASSERT_EQ(range.size(), n);
  ASSERT_EQ(amplitude.size(), n);
  ASSERT_EQ(flags.size(), n);
  EXPECT_TRUE(images->contains("moment_depth"));
  const PinholeIntrinsics intrinsics = daemon.pipeline().camera().intrinsics;
  int without_depth = 0;
  for (int64_t p = 0; p < kGeometry.pixel_count(); ++p) {
    const size_t i = static_cast<size_t>(p);
    EXPECT_EQ(amplitude[i], PatternAmplitude(p)) << p;
    if (!HasDepth(p)) {
      ++without_depth;
      EXPECT_TRUE(std::isnan(depth[i])) << p;
      EXPECT_TRUE(std::isnan(range[i])) << p;
      EXPECT_EQ(flags[i], static_cast<float>(kFlagNoReturn)) << p;
      continue;
    }
    EXPECT_EQ(depth[i], PatternDepth(p)) << p;
    EXPECT_EQ(flags[i], 0.0f) << p;
    const Vec3 ray = PixelRay(intrinsics, static_cast<double>(p % kGeometry.width),
                              static_cast<double>(p / kGeometry.width));
    const double expected = PatternDepth(p) / ray.z;  // Z * |((x-cx)/fx, (y-cy)/fy, 1)|
    EXPECT_NEAR(range[i], expected, kFloatRelative * expected) << p;
  }
  EXPECT_GT(without_depth, 0);
}

TEST(DepthSourceDaemon, DepthInMillimetresIsTheGivenDepthRounded) {
  Daemon daemon(DepthCamera(/*amplitude=*/false));
  v1::StreamRequest request = Request({v1::DEPTH, v1::RANGE});
  request.set_encoding(v1::UINT16_MM);
  absl::StatusOr<std::map<std::string, std::vector<float>>> images =
      FirstDecodedFrame(daemon, request);
  ASSERT_THAT(images.status(), IsOk());
  const std::vector<float>& depth = (*images)["depth"];
  ASSERT_EQ(depth.size(), static_cast<size_t>(kGeometry.pixel_count()));
  for (int64_t p = 0; p < kGeometry.pixel_count(); ++p) {
    const float got = depth[static_cast<size_t>(p)];
    if (!HasDepth(p)) {
      EXPECT_TRUE(std::isnan(got)) << p << ": 0 mm decodes as no depth";
      continue;
    }
    EXPECT_FLOAT_EQ(got, static_cast<float>(std::round(PatternDepth(p) * 1000.0) / 1000.0)) << p;
  }
}

TEST(DepthSourceDaemon, MomentDepthSpansZeroToTheMaximumDepthByDefault) {
  Daemon daemon(DepthCamera(/*amplitude=*/false));
  absl::StatusOr<v1::Frame> frame = FirstFrame(daemon, Request({v1::MOMENT_DEPTH}));
  ASSERT_THAT(frame.status(), IsOk());
  ASSERT_EQ(frame->images_size(), 1);
  EXPECT_EQ(frame->images(0).moment_depth().near_m(), 0.0);
  EXPECT_EQ(frame->images(0).moment_depth().far_m(), kMaxDepthM);
}

TEST(DepthSourceDaemon, RefusesWhatNeedsModulatedCapturesSayingWhy) {
  Daemon daemon(DepthCamera(/*amplitude=*/true));
  for (v1::Product product : {v1::C0, v1::MOMENT_STATE, v1::SLICES, v1::CUMULATIVE,
                              v1::DIRECT_INDIRECT, v1::CONFIDENCE}) {
    SCOPED_TRACE(v1::Product_Name(product));
    EXPECT_THAT(FirstDecodedFrame(daemon, Request({v1::DEPTH, product})).status(),
                StatusIs(absl::StatusCode::kFailedPrecondition,
                         HasSubstr(absl::StrCat(v1::Product_Name(product), ": ", kRefused))));
  }
  v1::StreamRequest returns = Request({v1::MOMENT_DEPTH});
  returns.mutable_moment_depth()->set_from_returns(true);
  EXPECT_THAT(FirstDecodedFrame(daemon, returns).status(),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("a moment depth map of the Pisarenko returns")));

  grpc::ClientContext pixel_context;
  v1::GetPixelRequest pixel_request;
  pixel_request.set_x(3);
  pixel_request.set_y(4);
  v1::Pixel pixel;
  const grpc::Status pixel_status = daemon.Stub()->GetPixel(&pixel_context, pixel_request, &pixel);
  EXPECT_EQ(pixel_status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(pixel_status.error_message(), HasSubstr(kRefused));

  grpc::ClientContext calibrate_context;
  v1::CalibrateRequest calibrate;
  calibrate.set_takes(2);
  auto progress = daemon.Stub()->Calibrate(&calibrate_context, calibrate);
  v1::CalibrateProgress message;
  while (progress->Read(&message)) {
  }
  const grpc::Status calibrate_status = progress->Finish();
  EXPECT_EQ(calibrate_status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(calibrate_status.error_message(), HasSubstr(kRefused));

  grpc::ClientContext record_context;
  v1::StartRecordingRequest record;
  record.set_path("depth_source_test.h5");
  v1::Recording recording;
  const grpc::Status record_status =
      daemon.Stub()->StartRecording(&record_context, record, &recording);
  EXPECT_EQ(record_status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(record_status.error_message(),
              HasSubstr(absl::StrCat(kRefused, "the capture file format")));

  // The refusals did not stop the stream of what it serves.
  EXPECT_THAT(FirstDecodedFrame(daemon, Request({v1::DEPTH})).status(), IsOk());
}

TEST(DepthSourceDaemon, AmplitudeIsRefusedWhenTheSourceDeliversNone) {
  Daemon daemon(DepthCamera(/*amplitude=*/false));
  EXPECT_THAT(FirstDecodedFrame(daemon, Request({v1::DEPTH, v1::AMPLITUDE})).status(),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("AMPLITUDE: the source delivers depth without an amplitude")));
  grpc::ClientContext context;
  v1::Info info;
  ASSERT_TRUE(daemon.Stub()->GetInfo(&context, {}, &info).ok());
  EXPECT_THAT(info.products(), ElementsAre(v1::RANGE, v1::DEPTH, v1::FLAGS, v1::MOMENT_DEPTH));
  EXPECT_EQ(info.schedule().raw_frames_per_frame(), 1u);
}

TEST(DepthSourceDaemon, InfoListsTheServedProductsAndTheMaximumDepth) {
  Daemon daemon(DepthCamera(/*amplitude=*/true));
  grpc::ClientContext context;
  v1::Info info;
  ASSERT_TRUE(daemon.Stub()->GetInfo(&context, {}, &info).ok());
  EXPECT_THAT(info.products(),
              ElementsAre(v1::RANGE, v1::DEPTH, v1::AMPLITUDE, v1::FLAGS, v1::MOMENT_DEPTH));
  EXPECT_EQ(info.unambiguous_range_m(), kMaxDepthM);
  EXPECT_EQ(info.schedule().sampling(), "depth");
  EXPECT_EQ(info.schedule().raw_frames_per_frame(), 2u);
  EXPECT_EQ(info.schedule().description(), "depth camera (Z up to 6 m), with amplitude: 2 raw frames");
  EXPECT_EQ(info.calibration(), "none");
  EXPECT_EQ(info.source_uri(), kUri);
}

TEST(DepthSourceDaemon, ACalibrationIsRefusedAtStart) {
  // A valid table for this sensor (a Dirac at zero measured perfectly), for a modulated camera.
  MomentImage dirac(kGeometry, 3);
  std::fill(dirac.real.begin(), dirac.real.end(), 1.0f);
  std::fill(dirac.imag.begin(), dirac.imag.end(), 0.0f);
  absl::StatusOr<CalibrationTable> table = EstimateCalibration(dirac, ScheduleOptions{}, 1);
  ASSERT_THAT(table.status(), IsOk());
  PipelineOptions options = DepthCamera(/*amplitude=*/true);
  options.calibration = *std::move(table);
  options.calibration_origin = "calibration.h5";
  EXPECT_THAT(Pipeline::Create(std::move(options)).status(),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr(absl::StrCat("calibration.h5 does not fit test:depth: ", kRefused,
                                              "a calibration table"))));
}

}  // namespace
}  // namespace transient::service
