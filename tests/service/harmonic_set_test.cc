// transientd on a camera whose harmonics are not 1..m: the simulated Kinect v2 (harmonics 10,
// 2, 15 of 8 MHz, three steps). Range, depth, amplitude, confidence and flags by phase
// unwrapping against the scene's truth; the moment reconstruction's products refused with the
// missing harmonics named, and the unwrapping's confidence refused on a moment schedule. A real
// daemon in this process, real gRPC on loopback.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "tests/service/daemon_fixture.h"
#include "tests/support/status_matchers.h"
#include "transient/drivers/calibration_capture.h"
#include "transient/drivers/capture_source.h"
#include "transient/reconstruct/percentile.h"

namespace transient::service {
namespace {

using ::testing::HasSubstr;
using ::transient::service::testing::Daemon;
using ::transient::service::testing::FirstDecodedFrame;
using ::transient::service::testing::kSmallSim;
using ::transient::service::testing::Request;
using ::transient::testing::IsOk;

// A quarter of the Kinect v2's sensor keeps the test short; everything else is the camera's.
constexpr char kCamera[] = "camera=kinect2&width=128&height=106&pace=fast";

PipelineOptions CalibratedKinect(absl::string_view scene) {
  PipelineOptions options;
  options.source_uri = absl::StrCat("sim:", scene, "?", kCamera);
  absl::StatusOr<std::unique_ptr<CaptureSource>> calibration =
      OpenSource(absl::StrCat("sim:calibration?", kCamera));
  EXPECT_THAT(calibration.status(), IsOk());
  if (!calibration.ok()) return options;
  absl::StatusOr<CalibrationCapture> measured = CaptureCalibration(**calibration, 8);
  EXPECT_THAT(measured.status(), IsOk());
  if (measured.ok()) options.calibration = std::move(measured->table);
  options.calibration_origin = "measured";
  return options;
}

TEST(HarmonicSetDaemon, ServesRangeDepthAmplitudeAndConfidenceByUnwrapping) {
  Daemon daemon(CalibratedKinect("corner"));
  absl::StatusOr<std::unique_ptr<CaptureSource>> truth_source =
      OpenSource(absl::StrCat("sim:corner?", kCamera));
  ASSERT_THAT(truth_source.status(), IsOk());
  absl::StatusOr<GroundTruth> truth = (*truth_source)->GroundTruthAt(0.0);
  ASSERT_THAT(truth.status(), IsOk());

  absl::StatusOr<std::map<std::string, std::vector<float>>> images = FirstDecodedFrame(
      daemon, Request({v1::RANGE, v1::DEPTH, v1::AMPLITUDE, v1::CONFIDENCE, v1::FLAGS}));
  ASSERT_THAT(images.status(), IsOk());
  const std::vector<float>& range = (*images)["range"];
  const std::vector<float>& flags = (*images)["flags"];
  ASSERT_EQ(range.size(), truth->first_range_m.size());
  std::vector<double> errors, confidence;
  int dead_columns_invalid = 0;
  for (size_t p = 0; p < range.size(); ++p) {
    const int x = static_cast<int>(p % 128);
    if (x == 0 || x == 127) {  // the camera's unreadable columns
      dead_columns_invalid += std::isnan(range[p]) && (static_cast<int>(flags[p]) & kFlagSaturated);
      continue;
    }
    if (std::isfinite(range[p]) && std::isfinite(truth->first_range_m[p])) {
      errors.push_back(std::abs(range[p] - truth->first_range_m[p]));
      confidence.push_back((*images)["confidence"][p]);
    }
    EXPECT_EQ(std::isnan((*images)["depth"][p]), std::isnan(range[p])) << p;
  }
  EXPECT_EQ(dead_columns_invalid, 2 * 106);
  // The corner's interreflection biases every single-return method (multipath); measured:
  // median 2.0 cm, 95th percentile 5.4 cm, confidence median 0.999, every pixel with a range.
  const double median = Percentile(errors, 50.0);
  EXPECT_GT(errors.size(), 0.95 * 126 * 106) << "share of pixels with a range";
  EXPECT_LT(median, 0.04);
  EXPECT_LT(Percentile(errors, 95.0), 0.10);
  EXPECT_GT(Percentile(confidence, 50.0), 0.95);
  RecordProperty("kinect2_corner_median_range_error_m", absl::StrCat(median));
  RecordProperty("kinect2_corner_p95_range_error_m", absl::StrCat(Percentile(errors, 95.0)));
}

TEST(HarmonicSetDaemon, RefusesTheMomentReconstructionNamingTheMissingHarmonics) {
  Daemon daemon(absl::StrCat("sim:mirrors?", kCamera));
  for (v1::Product product :
       {v1::C0, v1::MOMENT_STATE, v1::SLICES, v1::CUMULATIVE, v1::DIRECT_INDIRECT}) {
    SCOPED_TRACE(v1::Product_Name(product));
    absl::StatusOr<std::map<std::string, std::vector<float>>> images =
        FirstDecodedFrame(daemon, Request({v1::RANGE, product}));
    EXPECT_EQ(images.status().code(), absl::StatusCode::kFailedPrecondition);
    EXPECT_THAT(images.status().message(),
                HasSubstr("the schedule measures harmonics 2, 10, 15 of 8 MHz; the moment "
                          "reconstruction needs every harmonic 1..15 (missing 1, 3-9, 11-14)"));
  }
  v1::StreamRequest returns = Request({v1::MOMENT_DEPTH});
  returns.mutable_moment_depth()->set_from_returns(true);
  EXPECT_EQ(FirstDecodedFrame(daemon, returns).status().code(), absl::StatusCode::kFailedPrecondition);
  // Of the depth it works, and the refusals above did not stop the daemon.
  absl::StatusOr<std::map<std::string, std::vector<float>>> moment_depth =
      FirstDecodedFrame(daemon, Request({v1::MOMENT_DEPTH, v1::RANGE}));
  ASSERT_THAT(moment_depth.status(), IsOk());
  EXPECT_TRUE(moment_depth->contains("moment_depth"));

  grpc::ClientContext pixel_context;
  v1::GetPixelRequest pixel_request;
  pixel_request.set_x(10);
  pixel_request.set_y(10);
  v1::Pixel pixel;
  const grpc::Status pixel_status =
      daemon.Stub()->GetPixel(&pixel_context, pixel_request, &pixel);
  EXPECT_EQ(pixel_status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(pixel_status.error_message(), HasSubstr("missing 1, 3-9, 11-14"));

  grpc::ClientContext info_context;
  v1::Info info;
  ASSERT_TRUE(daemon.Stub()->GetInfo(&info_context, {}, &info).ok());
  EXPECT_THAT(info.products(),
              ::testing::ElementsAre(v1::RANGE, v1::DEPTH, v1::AMPLITUDE, v1::FLAGS,
                                     v1::MOMENT_DEPTH, v1::CONFIDENCE));
  EXPECT_THAT(info.schedule().harmonics(), ::testing::ElementsAre(10u, 2u, 15u));
  EXPECT_EQ(info.schedule().buckets(), 3u);
  EXPECT_EQ(info.schedule().order(), 15u);
}

TEST(HarmonicSetDaemon, ConfidenceIsRefusedOnAScheduleWithEveryHarmonic) {
  Daemon daemon(absl::StrCat(kSmallSim, "&pace=fast"));
  absl::StatusOr<std::map<std::string, std::vector<float>>> images =
      FirstDecodedFrame(daemon, Request({v1::RANGE, v1::CONFIDENCE}));
  EXPECT_EQ(images.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(images.status().message(), HasSubstr("measures every harmonic 1..3"));
}

}  // namespace
}  // namespace transient::service
