// client.h against a real transientd in this process (pipeline and gRPC server on a loopback
// port): connecting and failing to, each unary RPC with good and bad requests, Calibrate with
// progress and cancel, and the deadline of unary calls (a slow fake).
#include "transient/client/client.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <limits>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "tests/client/connect.h"
#include "tests/client/fake_transient.h"
#include "tests/service/daemon_fixture.h"
#include "tests/support/network.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "tests/support/wait.h"

namespace transient::client {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::transient::service::testing::Daemon;
using ::transient::service::testing::kSmallSim;
using ::transient::testing::ClosedPort;
using ::transient::testing::IsOk;
using ::transient::testing::MustConnect;
using ::transient::testing::SecondsSince;
using ::transient::testing::StatusIs;

TEST(ConnectOptions, BadValuesAreRefusedNamingTheField) {
  EXPECT_THAT((ConnectOptions{.address = "127.0.0.1:1"}).Validate(), IsOk());
  EXPECT_THAT((ConnectOptions{}).Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("address = \"\"")));
  EXPECT_THAT((ConnectOptions{.address = "127.0.0.1:1", .timeout_s = 0.0}).Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("timeout_s = 0. Violated constraint: finite and > 0")));
  EXPECT_THAT((ConnectOptions{.address = "127.0.0.1:1",
                              .call_timeout_s = std::numeric_limits<double>::quiet_NaN()})
                  .Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("call_timeout_s = nan")));
  // Connect checks them before it tries anything.
  EXPECT_THAT(Client::Connect({.address = "127.0.0.1:1", .timeout_s = -1.0}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("timeout_s = -1")));
}

TEST(Client, NothingListeningIsUnavailableNamingTheAddressWithinTheTimeout) {
  const std::string address = absl::StrCat("127.0.0.1:", ClosedPort());
  const auto start = std::chrono::steady_clock::now();
  EXPECT_THAT(Client::Connect({.address = address, .timeout_s = 0.5}).status(),
              StatusIs(absl::StatusCode::kUnavailable,
                       HasSubstr("cannot reach transientd at " + address + " within 0.5 s")));
  EXPECT_GE(SecondsSince(start), 0.5);
  EXPECT_LT(SecondsSince(start), 5.0);  // generous for a loaded CI machine
}

TEST(Client, CancelWhileConnectingIsCancelledLongBeforeTheTimeout) {
  const std::string address = absl::StrCat("127.0.0.1:", ClosedPort());
  std::atomic<bool> cancel{false};
  std::thread canceller([&cancel] {
    absl::SleepFor(absl::Milliseconds(200));
    cancel = true;
  });
  const auto start = std::chrono::steady_clock::now();
  EXPECT_THAT(
      Client::Connect({.address = address, .timeout_s = 30.0, .cancel = &cancel}).status(),
      StatusIs(absl::StatusCode::kCancelled,
               HasSubstr("interrupted while connecting to transientd at " + address)));
  EXPECT_LT(SecondsSince(start), 10.0);  // well before the 30 s timeout
  canceller.join();
}

TEST(Client, GetInfoDescribesTheDaemonsCamera) {
  Daemon daemon(kSmallSim);
  const Client client = MustConnect(daemon.address());
  EXPECT_EQ(client.address(), daemon.address());
  const absl::StatusOr<v1::Info> info = client.GetInfo();
  ASSERT_THAT(info.status(), IsOk());
  EXPECT_EQ(info->camera().width(), 32u);
  EXPECT_EQ(info->camera().height(), 24u);
  EXPECT_EQ(info->source_uri(), kSmallSim);
  EXPECT_EQ(info->version(), "test");
  EXPECT_EQ(info->products_size(), 10);
}

TEST(Client, SetConfigChangesWhatIsSetAndABadValueIsTheDaemonsInvalidArgument) {
  Daemon daemon(kSmallSim);
  const Client client = MustConnect(daemon.address());
  v1::Config update;
  update.set_threshold(0.25);
  const absl::StatusOr<v1::Config> changed = client.SetConfig(update);
  ASSERT_THAT(changed.status(), IsOk());
  EXPECT_DOUBLE_EQ(changed->threshold(), 0.25);
  update.set_threshold(2.0);  // outside (0, 1)
  EXPECT_THAT(client.SetConfig(update).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("SetConfig from transientd at " + daemon.address() + ": "),
                             HasSubstr("threshold"))));
  // Nothing changed.
  const absl::StatusOr<v1::Config> now = client.GetConfig();
  ASSERT_THAT(now.status(), IsOk());
  EXPECT_DOUBLE_EQ(now->threshold(), 0.25);
}

TEST(Client, GetPixelOfTheLatestFrameAndOutsideTheSensorIsInvalidArgument) {
  Daemon daemon(kSmallSim);
  ASSERT_TRUE(daemon.WaitForFirstFrame());
  const Client client = MustConnect(daemon.address());
  v1::GetPixelRequest request;
  request.set_x(16);
  request.set_y(12);
  request.set_bins(32);
  const absl::StatusOr<v1::Pixel> pixel = client.GetPixel(request);
  ASSERT_THAT(pixel.status(), IsOk());
  EXPECT_EQ(pixel->x(), 16u);
  EXPECT_EQ(pixel->time_of_flight_ns_size(), 32);
  request.set_x(32);
  EXPECT_THAT(client.GetPixel(request).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("GetPixel from transientd at "),
                             HasSubstr("outside the 32x24 sensor"))));
}

TEST(Client, RecordingStartsAndStopsAndRefusesWhatTheDaemonRefuses) {
  Daemon daemon(kSmallSim);
  const Client client = MustConnect(daemon.address());
  EXPECT_THAT(client.StopRecording().status(),
              StatusIs(absl::StatusCode::kFailedPrecondition, HasSubstr("StopRecording from")));
  v1::StartRecordingRequest request;
  request.set_path("capture.h5");
  const absl::StatusOr<v1::Recording> started = client.StartRecording(request);
  ASSERT_THAT(started.status(), IsOk());
  EXPECT_TRUE(started->active());
  EXPECT_EQ(started->path(), "capture.h5");
  const absl::StatusOr<v1::Recording> stopped = client.StopRecording();
  ASSERT_THAT(stopped.status(), IsOk());
  EXPECT_FALSE(stopped->active());
  EXPECT_TRUE(std::filesystem::exists(daemon.DataFile("capture.h5")));
  // A file is never replaced.
  EXPECT_THAT(client.StartRecording(request).status(),
              StatusIs(absl::StatusCode::kAlreadyExists, HasSubstr("StartRecording from")));
}

TEST(Client, GetStatsCountsTheFramesAndTheSubscriber) {
  Daemon daemon(kSmallSim);
  const Client client = MustConnect(daemon.address());
  v1::StreamRequest request;
  request.add_products(v1::RANGE);
  std::unique_ptr<FrameStream> stream = client.StreamFrames(request);
  StreamFrame frame;
  ASSERT_TRUE(stream->Next(&frame));
  const absl::StatusOr<v1::Stats> stats = client.GetStats();
  ASSERT_THAT(stats.status(), IsOk());
  EXPECT_GE(stats->frames_published(), 1u);
  ASSERT_EQ(stats->subscribers_size(), 1);
  EXPECT_GE(stats->subscribers(0).frames_sent(), 1u);
  EXPECT_THAT(stream->Finish(), IsOk());
}

TEST(Client, CalibrateReportsEachTakeThenTheResult) {
  Daemon daemon(kSmallSim);
  const Client client = MustConnect(daemon.address());
  v1::CalibrateRequest request;
  request.set_takes(4);
  request.set_output_path("calibration.h5");
  std::vector<std::pair<int, int>> progress;
  const absl::StatusOr<v1::CalibrateResult> result =
      client.Calibrate(request, [&](int done, int total) { progress.push_back({done, total}); });
  ASSERT_THAT(result.status(), IsOk());
  // One message per take, then the result with done = total.
  ASSERT_EQ(progress.size(), 5u);
  EXPECT_EQ(progress.front(), std::make_pair(1, 4));
  EXPECT_EQ(progress.back(), std::make_pair(4, 4));
  EXPECT_TRUE(result->applied());
  EXPECT_EQ(result->pixels(), 32u * 24u);
  EXPECT_EQ(result->output_path(), "calibration.h5");
  EXPECT_TRUE(std::filesystem::exists(daemon.DataFile("calibration.h5")));
  // The same path again is the daemon's AlreadyExists.
  EXPECT_THAT(client.Calibrate(request).status(),
              StatusIs(absl::StatusCode::kAlreadyExists,
                       HasSubstr("Calibrate from transientd at " + daemon.address())));
}

TEST(Client, CalibrateIsCancelledWhenTheFlagTurns) {
  Daemon daemon(kSmallSim);
  const Client client = MustConnect(daemon.address());
  v1::CalibrateRequest request;
  // The calibration scene at the camera's pace, 12.5 frames/s: 256 takes are about 20 s, so
  // only the cancel ends it early (the default source would be the scene at full speed).
  request.set_source_uri("sim:calibration?width=32&height=24");
  request.set_takes(256);
  std::atomic<bool> cancel{false};
  int calls = 0;
  const auto start = std::chrono::steady_clock::now();
  const absl::StatusOr<v1::CalibrateResult> result = client.Calibrate(
      request,
      [&](int done, int) {
        ++calls;
        if (done == 2) cancel = true;
      },
      &cancel);
  EXPECT_THAT(result.status(), StatusIs(absl::StatusCode::kCancelled, HasSubstr("interrupted")));
  EXPECT_GE(calls, 2);
  EXPECT_LT(SecondsSince(start), 10.0);
}

TEST(Client, UnaryCallsEndAtTheirDeadline) {
  // A fake: the real daemon answers GetInfo from memory, never slowly.
  class SlowTransient final : public v1::Transient::Service {
    grpc::Status GetInfo(grpc::ServerContext* context, const v1::GetInfoRequest*,
                         v1::Info*) override {
      const absl::Time until = absl::Now() + absl::Seconds(5);
      while (!context->IsCancelled() && absl::Now() < until) {
        absl::SleepFor(absl::Milliseconds(10));
      }
      return grpc::Status::OK;
    }
  } service;
  transient::testing::FakeDaemon daemon(&service);
  absl::StatusOr<Client> client =
      Client::Connect({.address = daemon.address(), .call_timeout_s = 0.2});
  ASSERT_THAT(client.status(), IsOk());
  const auto start = std::chrono::steady_clock::now();
  EXPECT_THAT(client->GetInfo().status(),
              StatusIs(absl::StatusCode::kDeadlineExceeded, HasSubstr("GetInfo from transientd")));
  EXPECT_LT(SecondsSince(start), 4.0);
}

}  // namespace
}  // namespace transient::client
