// The openni2: source (drivers/src/openni2/) under Debian's libOpenNI2 from the build's private
// runtime: a recording that OpenNI2's own Recorder made of transientd's OpenNI2 device
// (openni_only_reader, through the driver of openni2/) read back, in this process through
// OpenSource and through a second transientd, and its bad inputs.
#include <OpenNI.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/openni2/openni2_test_support.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/subprocess.h"
#include "tests/support/wait.h"
#include "transient/client/client.h"
#include "transient/drivers/capture_devices.h"
#include "transient/drivers/capture_source.h"
#include "transient/openni2/oni_frames.h"

namespace transient {
namespace {

using ::testing::HasSubstr;
using testing::ChildProcess;
using testing::ScratchDirectory;
using testing::WaitForPortFile;
using testing::WaitUntil;

// A recording of transientd's OpenNI2 device (640 x 480 mm, the device's default; with `ir`,
// its IR stream too), and its frames as OpenNI2's own player gives them, in the order played.
struct Recording {
  std::string path;
  std::vector<ReaderFrame> frames;
};

Recording Record(const ScratchDirectory& scratch, bool ir = false) {
  Daemon daemon(scratch);
  EXPECT_GT(daemon.port(), 0);
  Recording recording{.path = scratch.File("capture.oni"), .frames = {}};
  std::vector<std::string> args = {"record", daemon.uri(), "5", recording.path};
  if (ir) args.push_back("ir");
  const testing::ProcessResult record = RunReader(args);
  EXPECT_EQ(record.exit_code, 0) << record.err;
  const testing::ProcessResult play = RunReader({"play", recording.path, scratch.File("p.bin")});
  EXPECT_EQ(play.exit_code, 0) << play.err;
  recording.frames = ReadFrames(scratch.File("p.bin"));
  return recording;
}

TEST(OpenNi2Source, AFastReplayGivesEveryRecordedFrameOnceThenEnds) {
  ScratchDirectory scratch;
  const Recording recording = Record(scratch);
  ASSERT_GE(recording.frames.size(), 3u);
  absl::StatusOr<std::unique_ptr<CaptureSource>> source =
      OpenSource(absl::StrCat("openni2:", recording.path, "?pace=fast"));
  ASSERT_TRUE(source.ok()) << source.status();
  const CameraInfo& camera = (*source)->camera();
  EXPECT_EQ(camera.geometry.width, 640);
  EXPECT_EQ(camera.geometry.height, 480);
  EXPECT_DOUBLE_EQ(camera.intrinsics.cx, 319.5);
  EXPECT_NEAR(camera.intrinsics.fx, camera.intrinsics.fy, 1e-3) << "the driver's square pixels";
  EXPECT_TRUE((*source)->schedule().options().DeliversDepth());
  EXPECT_TRUE((*source)->capabilities().replay);
  EXPECT_TRUE((*source)->capabilities().waits_for_consumer);
  ASSERT_TRUE((*source)->Start().ok());
  RawFrame frame;
  size_t delivered = 0;
  absl::Status status;
  while ((status = (*source)->Next(absl::Seconds(5), &frame)).ok()) {
    ASSERT_LT(delivered, recording.frames.size());
    const ReaderFrame& played = recording.frames[delivered];
    ASSERT_EQ(frame.pixels.size(), played.pixels.size());
    int with_depth = 0;
    for (size_t i = 0; i < played.pixels.size(); ++i) {
      // Z in metres, back to the recording's millimetres exactly; 0 = NaN.
      ASSERT_EQ(openni2::DepthCount(frame.pixels[i], openni2::DepthUnit::kMillimetre, 65534),
                played.pixels[i]) << "frame " << delivered << " pixel " << i;
      with_depth += played.pixels[i] != 0;
    }
    EXPECT_GT(with_depth, 0);
    EXPECT_DOUBLE_EQ(frame.config.timestamp_s, played.timestamp_us * 1e-6);
    ++delivered;
  }
  EXPECT_TRUE(absl::IsOutOfRange(status)) << status;
  EXPECT_EQ(delivered, recording.frames.size()) << "every frame once";
}

TEST(OpenNi2Source, IrOfTheSameCaptureBecomesTheCyclesAmplitude) {
  ScratchDirectory scratch;
  const Recording recording = Record(scratch, /*ir=*/true);
  std::vector<ReaderFrame> depth, ir;
  for (const ReaderFrame& frame : recording.frames) {
    (frame.format == openni::PIXEL_FORMAT_GRAY16 ? ir : depth).push_back(frame);
  }
  ASSERT_GE(depth.size(), 3u);
  ASSERT_GE(ir.size(), 3u);
  absl::StatusOr<std::unique_ptr<CaptureSource>> source =
      OpenSource(absl::StrCat("openni2:", recording.path, "?pace=fast"));
  ASSERT_TRUE(source.ok()) << source.status();
  EXPECT_TRUE((*source)->schedule().options().depth_amplitude);
  ASSERT_TRUE((*source)->Start().ok());
  RawFrame frame;
  absl::Status status;
  int cycles = 0;
  while ((status = (*source)->Next(absl::Seconds(5), &frame)).ok()) {
    ASSERT_EQ(frame.config.content, FrameContent::kDepth);
    const double timestamp_s = frame.config.timestamp_s;
    const std::vector<float> z = frame.pixels;
    ASSERT_TRUE((*source)->Next(absl::Seconds(5), &frame).ok()) << "the cycle's amplitude";
    ASSERT_EQ(frame.config.content, FrameContent::kAmplitude);
    EXPECT_EQ(frame.config.cycle, cycles);
    // The IR frame of the same capture: the driver gave both the capture's timestamp.
    EXPECT_DOUBLE_EQ(frame.config.timestamp_s, timestamp_s);
    bool found = false;
    for (size_t i = 0; i < ir.size() && !found; ++i) {
      if (ir[i].timestamp_us * 1e-6 != timestamp_s) continue;
      found = true;
      for (size_t p = 0; p < ir[i].pixels.size(); ++p) {
        ASSERT_EQ(frame.pixels[p], static_cast<float>(ir[i].pixels[p])) << "pixel " << p;
      }
      ASSERT_EQ(z.size(), depth[0].pixels.size());
    }
    EXPECT_TRUE(found) << "an amplitude frame of no recorded IR frame";
    ++cycles;
  }
  EXPECT_TRUE(absl::IsOutOfRange(status)) << status;
  EXPECT_GE(cycles, 3);
  EXPECT_LE(cycles, static_cast<int>(std::min(depth.size(), ir.size())));
}

TEST(OpenNi2Source, TransientdServesTheRecordingsDepthAndRefusesTransientProducts) {
  ScratchDirectory scratch;
  const Recording recording = Record(scratch);
  ASSERT_GE(recording.frames.size(), 3u);
  const std::string port_file = scratch.File("replay_port");
  ChildProcess replay({TRANSIENTD_BINARY, "--source",
                       absl::StrCat("openni2:", recording.path, "?loop=1"), "--listen",
                       "127.0.0.1:0", "--port-file", port_file},
                      scratch.File("replay.log"));
  const int port = WaitForPortFile(port_file);
  ASSERT_GT(port, 0);
  const std::string address = absl::StrCat("127.0.0.1:", port);
  GrpcFrames grpc(address, /*amplitude=*/false);
  const v1::Info& info = grpc.info();
  EXPECT_EQ(info.camera().width(), 640u);
  EXPECT_EQ(info.schedule().sampling(), "depth");
  ASSERT_TRUE(WaitUntil([&] { return grpc.size() >= 3; }, absl::Seconds(30)));
  for (const GrpcFrames::Frame& sent : grpc.All()) {
    bool found = false;
    for (const ReaderFrame& played : recording.frames) found |= played.pixels == sent.depth_mm;
    EXPECT_TRUE(found) << "a served depth frame that is no frame of the recording";
  }
  // Range from that depth along the rays of the fields of view.
  absl::StatusOr<client::Client> daemon = client::Client::Connect({.address = address});
  ASSERT_TRUE(daemon.ok());
  v1::StreamRequest transient_video;
  transient_video.add_products(v1::SLICES);
  std::unique_ptr<client::FrameStream> refused = daemon->StreamFrames(transient_video);
  client::StreamFrame frame;
  EXPECT_FALSE(refused->Next(&frame));
  const absl::Status status = refused->Finish();
  EXPECT_TRUE(absl::IsFailedPrecondition(status)) << status;
  EXPECT_THAT(status.message(), HasSubstr("delivers depth"));
}

TEST(OpenNi2Source, BadUrisAndFilesAreRefusedWithTheReason) {
  ScratchDirectory scratch;
  const auto refused = [](const std::string& uri) {
    absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource(uri);
    return source.ok() ? absl::OkStatus() : source.status();
  };
  absl::Status status = refused(absl::StrCat("openni2:", scratch.File("missing.oni")));
  EXPECT_TRUE(absl::IsNotFound(status)) << status;
  EXPECT_THAT(status.message(), HasSubstr("missing.oni"));
  status = refused("openni2:transient://127.0.0.1:50051");
  EXPECT_TRUE(absl::IsInvalidArgument(status)) << status;
  EXPECT_THAT(status.message(), HasSubstr("its own"));
  status = refused("openni2:x.oni?speed=2");
  EXPECT_TRUE(absl::IsInvalidArgument(status)) << status;
  EXPECT_THAT(status.message(), HasSubstr("speed"));
  for (const char* bad : {"openni2:x.oni?fx=-1", "openni2:x.oni?ir=2", "openni2:x.oni?pace=slow",
                          "openni2:x.oni?loop=yes", "openni2:x.oni?cx=nan"}) {
    status = refused(bad);
    EXPECT_TRUE(absl::IsInvalidArgument(status)) << bad << ": " << status;
  }
  // No OpenNI2 device here (the private runtime has none but transientd's own, silenced).
  status = refused("openni2:");
  EXPECT_TRUE(absl::IsNotFound(status)) << status;
  // Not a recording: text, and a recording cut short.
  const std::string text = scratch.File("text.oni");
  std::ofstream(text) << "not an OpenNI2 recording\n";
  EXPECT_FALSE(refused(absl::StrCat("openni2:", text)).ok());
  const Recording recording = Record(scratch);
  const std::string cut = scratch.File("cut.oni");
  std::filesystem::copy_file(recording.path, cut);
  std::filesystem::resize_file(cut, 3000);
  absl::StatusOr<std::unique_ptr<CaptureSource>> source =
      OpenSource(absl::StrCat("openni2:", cut, "?pace=fast"));
  if (source.ok()) {
    // OpenNI2 may accept the header: then the frames that are not there never come.
    ASSERT_TRUE((*source)->Start().ok());
    RawFrame frame;
    const absl::Status next = (*source)->Next(absl::Seconds(1), &frame);
    EXPECT_FALSE(next.ok()) << "a frame from a file cut after its header";
  }
}

TEST(OpenNi2Source, DeviceListsAskOpenNi2ButNeverOfferTransientdsOwnDevice) {
  ScratchDirectory scratch;
  Daemon daemon(scratch);
  ASSERT_GT(daemon.port(), 0);
  // The driver would announce this daemon to any other program (openni2_driver_test.cc).
  setenv("TRANSIENT_OPENNI2_ADDRESS", daemon.address().c_str(), 1);
  const DeviceListOptions options{.dev_dir = scratch.path().string()};
  const std::vector<CaptureDevice> devices = ListCaptureDevices(options);
  for (const CaptureDevice& device : devices) {
    EXPECT_THAT(device.uri, ::testing::Not(HasSubstr("transient://")));
  }
  EXPECT_THAT(DescribeCaptureDevices(devices, options),
              HasSubstr("Kinect v2 cameras on USB and OpenNI2 devices"));
  // The program, as a user runs it.
  const testing::ProcessResult listed = testing::RunProcess({TRANSIENT_BINARY, "devices"});
  EXPECT_EQ(listed.exit_code, 0) << listed.err;
  EXPECT_THAT(listed.out, ::testing::Not(HasSubstr("transient://")));
  EXPECT_THAT(listed.out, HasSubstr("OpenNI2"));
}

}  // namespace
}  // namespace transient
