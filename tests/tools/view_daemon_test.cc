// `transient view daemon:ADDR`: frames received from a real transientd (pipeline and gRPC
// server in this process, on a loopback port) are drawn like a file's, lose nothing on the way,
// an unreachable daemon is named, and a replay that ends early leaves the frames it sent.
#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/time.h"
#include "tests/service/daemon_fixture.h"
#include "tests/support/network.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "tests/support/video_probe.h"
#include "tests/tools/image_readers.h"
#include "tools/transient/view/daemon_frame_source.h"
#include "tools/transient/view/view_command.h"
#include "transient/formats/capture_file.h"
#include "transient/client/decoded_image.h"
#include "transient/drivers/capture_source.h"
#include "transient/v1/transient.grpc.pb.h"

namespace transient::tools {
namespace {

using service::testing::Daemon;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::transient::client::DecodedImage;
using ::transient::client::DecodeFrame;
using ::transient::testing::ClosedPort;
using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;

// The small simulated camera without noise: every frame of its static scene is the same, so
// frames received by two subscribers can be compared value for value. 12.5 frames/s.
constexpr char kQuietSim[] = "sim:mirrors?width=32&height=24&noise=none";
constexpr ImageGeometry kSimGeometry{32, 24};
constexpr int kBins = 8;

ViewArgs DaemonArgs(const Daemon& daemon, const ScratchDirectory& dir) {
  ViewArgs args{.input_path = absl::StrCat("daemon:", daemon.address()),
                .output_dir = dir.File("out")};
  args.daemon_frames = 3;
  args.bins = kBins;
  return args;
}

TEST(ViewDaemon, DrawsEveryPictureOfTheFramesReceived) {
  Daemon daemon(kQuietSim);
  ScratchDirectory dir;
  const ViewArgs args = DaemonArgs(daemon, dir);
  const absl::StatusOr<ViewSummary> summary = RunView(args);
  ASSERT_THAT(summary.status(), IsOk());

  EXPECT_EQ(summary->input_kind, "transientd");
  EXPECT_EQ(summary->frames, 3);
  EXPECT_EQ(summary->geometry, kSimGeometry);
  EXPECT_TRUE(summary->notes.empty()) << summary->notes.front();
  // Nothing chosen: everything the daemon allows, the simulator's intrinsics placing points.
  const std::filesystem::path out = dir.path() / "out";
  for (int k = 0; k < 3; ++k) {
    const std::filesystem::path frame = out / absl::StrFormat("frame_%03d", k);
    SCOPED_TRACE(frame.string());
    for (int bin = 0; bin < kBins; ++bin) {
      EXPECT_TRUE(
          std::filesystem::exists(frame / "slices" / absl::StrFormat("slice_%03d.png", bin)));
      EXPECT_TRUE(
          std::filesystem::exists(frame / "cumulative" / absl::StrFormat("slice_%03d.png", bin)));
    }
    EXPECT_FALSE(std::filesystem::exists(frame / "slices" / "slice_008.png"));
    for (const char* name : {"streak_y012.png", "range.png", "amplitude.png", "flags.png",
                             "direct.png", "indirect.png", "pixel_x016_y012.png", "points.ply"}) {
      EXPECT_TRUE(std::filesystem::exists(frame / name)) << name;
    }
    // The daemon sends direct/indirect light but no range of the first Pisarenko return.
    EXPECT_FALSE(std::filesystem::exists(frame / "range_pisarenko.png"));
  }
  EXPECT_FALSE(std::filesystem::exists(out / "frame_003"));
  // Per frame: 8 slices, 8 cumulative, 1 streak, 5 images, 1 pixel plot.
  EXPECT_EQ(summary->png_files, 3 * (kBins + kBins + 1 + 5 + 1));
  EXPECT_EQ(summary->ply_files, 3);

  EXPECT_EQ(summary->video_frames, 3 * kBins);
  absl::StatusOr<::transient::testing::VideoInfo> video =
      ::transient::testing::ProbeVideo(dir.File("out/light.mp4"));
  ASSERT_THAT(video.status(), IsOk());
  EXPECT_EQ(video->frames, 3 * kBins);
  EXPECT_THAT(FormatViewSummary(*summary),
              HasSubstr(absl::StrCat(
                  "drew 3 frames of 32x24 px (transientd daemon:", daemon.address(), ")")));
}

TEST(ViewDaemon, DensityAndPlanesAreTheDaemonsImagesValueForValue) {
  Daemon daemon(kQuietSim);
  absl::StatusOr<std::unique_ptr<DaemonFrameSource>> source =
      DaemonFrameSource::Receive({.address = daemon.address(), .frames = 2, .bins = kBins});
  ASSERT_THAT(source.status(), IsOk());
  EXPECT_EQ((*source)->frames(), 2);
  EXPECT_EQ((*source)->bins(), kBins);
  EXPECT_EQ((*source)->geometry(), kSimGeometry);
  EXPECT_DOUBLE_EQ((*source)->base_frequency_hz(), 23e6);  // the simulator's default
  EXPECT_EQ((*source)->source_uri(), kQuietSim);
  ASSERT_TRUE((*source)->intrinsics().has_value());
  EXPECT_LT((*source)->sequences()[0], (*source)->sequences()[1]);
  TransientFrame frame;
  ASSERT_THAT((*source)->ReadFrame(1, (*source)->available(), &frame), IsOk());
  EXPECT_TRUE(frame.pisarenko_weight.empty());

  // A frame of the same static scene as a plain subscriber sees it.
  v1::StreamRequest request;
  for (v1::Product product : {v1::SLICES, v1::C0, v1::FLAGS}) request.add_products(product);
  request.mutable_slices()->set_bins(kBins);
  grpc::ClientContext context;
  std::unique_ptr<grpc::ClientReader<v1::Frame>> reader =
      daemon.Stub()->StreamFrames(&context, request);
  v1::Frame wire;
  do {
    ASSERT_TRUE(reader->Read(&wire));
  } while (wire.images_size() == 0);
  context.TryCancel();
  const absl::StatusOr<std::vector<DecodedImage>> images = DecodeFrame(wire);
  ASSERT_THAT(images.status(), IsOk());

  int slices = 0, finite = 0;
  for (const DecodedImage& image : *images) {
    SCOPED_TRACE(image.name);
    if (image.product == v1::SLICES) {
      const int bin = slices++;
      ASSERT_EQ(image.name, absl::StrCat("slices/", bin));
      // Bin n is at phase 2*pi*n/bins, the time of flight the daemon gave its image.
      constexpr double kNsTolerance = 1e-9;  // a few ulps of a 43 ns period
      EXPECT_NEAR(frame.BinTimeOfFlightNs(bin), image.time_of_flight_ns, kNsTolerance);
      for (int y = 0; y < kSimGeometry.height; ++y) {
        for (int x = 0; x < kSimGeometry.width; ++x) {
          const float expected = image.values[frame.pixel_index(x, y)];
          finite += std::isfinite(expected);
          ASSERT_EQ(frame.at(frame.density, bin, x, y), expected) << x << "," << y;
        }
      }
    } else if (image.product == v1::C0) {
      EXPECT_EQ(frame.c0, image.values);
    } else if (image.product == v1::FLAGS) {
      EXPECT_TRUE(std::equal(frame.flags.begin(), frame.flags.end(), image.values.begin()));
    }
  }
  EXPECT_EQ(slices, kBins);
  EXPECT_GT(finite, kBins * kSimGeometry.pixel_count() / 2);  // a lit scene, not all NaN
}

TEST(ViewDaemon, PicturesTheDaemonCannotGiveAreRefused) {
  Daemon daemon(kQuietSim);
  absl::StatusOr<std::unique_ptr<DaemonFrameSource>> source =
      DaemonFrameSource::Receive({.address = daemon.address(), .frames = 1, .bins = kBins});
  ASSERT_THAT(source.status(), IsOk());
  TransientFrame frame;
  EXPECT_THAT((*source)->ReadFrame(0, Products({Product::kDensity, Product::kBoundsLower}), &frame),
              StatusIs(absl::StatusCode::kNotFound,
                       HasSubstr(absl::StrCat("daemon:", daemon.address(),
                                              ": transientd sends no /bounds/lower"))));
  EXPECT_THAT((*source)->ReadFrame(1, Products({Product::kDensity}), &frame),
              StatusIs(absl::StatusCode::kOutOfRange, HasSubstr("frame 1 of 1 received")));
}

TEST(ViewDaemon, UnreachableAddressIsNamedAndNothingIsWritten) {
  ScratchDirectory dir;
  const std::string address = absl::StrCat("127.0.0.1:", ClosedPort());
  ViewArgs args{.input_path = absl::StrCat("daemon:", address), .output_dir = dir.File("out")};
  args.connect_timeout_s = 0.3;
  const absl::StatusOr<ViewSummary> summary = RunView(args);
  EXPECT_THAT(
      summary.status(),
      StatusIs(absl::StatusCode::kUnavailable,
               HasSubstr(absl::StrCat("cannot reach transientd at ", address, " within 0.3 s"))));
  EXPECT_FALSE(std::filesystem::exists(dir.File("out")));
}

TEST(ViewDaemon, DaemonOptionsAreCheckedBeforeConnecting) {
  ViewArgs args{.input_path = "daemon:", .output_dir = "/tmp/out"};
  EXPECT_THAT(args.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("daemon:HOST:PORT")));
  args.input_path = "daemon:127.0.0.1:1";
  args.daemon_frames = 0;
  EXPECT_THAT(args.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                        HasSubstr("--frames = 0: a daemon input takes")));
  args.daemon_frames = 4;
  args.bins = 2048;  // a file input may reconstruct 2048 phases; the daemon sends 1024 slices
  EXPECT_THAT(args.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("--bins = 2048")));
  args.bins = 64;
  args.frames = {.start = 0, .stop = 2};
  EXPECT_THAT(args.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("not a slice")));
}

// A capture file of `cycles` transient frames of the small simulated camera, for replay.
void WriteCapture(const std::string& path, int cycles) {
  service::testing::WriteCapture(
      absl::StrCat("sim:mirrors?width=32&height=24&pace=fast&frames=", cycles), path);
}

TEST(ViewDaemon, AReplayThatEndsEarlyDrawsTheFramesItSent) {
  // The replay starts once the view is subscribed, at the recording's pace (a faster replay
  // may drop a cycle at its end, see client_command_test), and ends after two frames.
  ScratchDirectory dir;
  const std::string capture = dir.File("two.h5");
  ASSERT_NO_FATAL_FAILURE(WriteCapture(capture, 2));
  Daemon daemon(absl::StrCat("replay:", capture, "?pace=realtime"), /*start=*/false);
  ViewArgs args = DaemonArgs(daemon, dir);
  args.daemon_frames = 4;
  args.images = true;
  absl::StatusOr<ViewSummary> summary = absl::UnknownError("not run");
  std::thread view([&] { summary = RunView(args); });
  EXPECT_TRUE(daemon.WaitForSubscribers(1));
  daemon.pipeline().Start();
  view.join();

  ASSERT_THAT(summary.status(), IsOk());
  EXPECT_EQ(summary->frames, 2);
  EXPECT_EQ(summary->png_files, 2 * 5);
  ASSERT_EQ(summary->notes.size(), 1u);
  EXPECT_THAT(summary->notes[0], AllOf(HasSubstr("transientd sent 2 of the 4 frames asked for"),
                                       HasSubstr("ended after 2 frames")));
  EXPECT_TRUE(std::filesystem::exists(dir.File("out/frame_001/range.png")));
  EXPECT_FALSE(std::filesystem::exists(dir.File("out/frame_002")));
}

TEST(ViewDaemon, AnEndedSourceWithNoFrameIsAnError) {
  ScratchDirectory dir;
  const std::string capture = dir.File("one.h5");
  ASSERT_NO_FATAL_FAILURE(WriteCapture(capture, 1));
  Daemon daemon(absl::StrCat("replay:", capture, "?pace=fast"));
  ASSERT_TRUE(daemon.WaitFor([&] { return daemon.Stats().state() == v1::ENDED; }));
  const ViewArgs args = DaemonArgs(daemon, dir);
  EXPECT_THAT(RunView(args).status(),
              StatusIs(absl::StatusCode::kOutOfRange,
                       AllOf(HasSubstr(absl::StrCat("stream from transientd at ", daemon.address(),
                                                    " ended after 0 of 3")),
                             HasSubstr("has ended"))));
  EXPECT_FALSE(std::filesystem::exists(dir.File("out")));
}

}  // namespace
}  // namespace transient::tools
