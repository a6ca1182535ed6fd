// The OpenNI2 driver (openni2/) under Debian's real libOpenNI2, loaded from the build's private
// runtime (ctest sets LD_LIBRARY_PATH to it: libOpenNI2.so.0 with only this driver and OniFile
// beside it), against a real transientd on the simulated camera, started as a child process.
// What the driver hands OpenNI2 is compared with what the daemon sends over gRPC for the same
// frame index (OpenNI2 keeps only a stream's latest frame, so frames are matched, not counted).
#include <OpenNI.h>
#include <PS1080.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/subprocess.h"
#include "tests/support/wait.h"
#include "transient/client/client.h"
#include "tests/openni2/openni2_test_support.h"
#include "transient/openni2/oni_frames.h"

namespace transient {
namespace {

using ::testing::HasSubstr;
using testing::ChildProcess;
using testing::ProcessResult;
using testing::RunProcess;
using testing::ScratchDirectory;
using testing::WaitForPortFile;
using testing::WaitUntil;

// "key=value" of the reader's output.
std::string Printed(const std::string& out, const std::string& key) {
  std::istringstream lines(out);
  std::string word;
  while (lines >> word) {
    if (word.rfind(key + "=", 0) == 0) return word.substr(key.size() + 1);
  }
  return "";
}

int CountNonZero(const std::vector<uint16_t>& pixels) {
  return static_cast<int>(std::count_if(pixels.begin(), pixels.end(), [](uint16_t v) { return v; }));
}

// The daemon's depth in mm at the nearest sensor pixel of the ideal pinhole's ray through
// (u, v), computed here from the fields of view as an application does (f from HFOV, principal
// point at the centre): independent of the driver's resampling code.
uint16_t ExpectedResampled(const GrpcFrames::Frame& frame, const v1::CameraInfo& camera, int width,
                           int height, double hfov, int u, int v) {
  const double f = width / (2.0 * std::tan(hfov / 2.0));
  const double x = (u - 0.5 * (width - 1)) / f, y = (v - 0.5 * (height - 1)) / f;
  const long col = std::lround(camera.fx() * x + camera.cx());
  const long row = std::lround(camera.fy() * y + camera.cy());
  if (col < 0 || row < 0 || col >= static_cast<long>(camera.width()) ||
      row >= static_cast<long>(camera.height())) {
    return 0;
  }
  return frame.depth_mm[static_cast<size_t>(row) * camera.width() + col];
}

// --- A program with only OpenNI.h --------------------------------------------------------------

TEST(OpenNi2Driver, AProgramWithOnlyOpenNiReadsTheDaemonsDepthInMillimetres) {
  ScratchDirectory scratch;
  Daemon daemon(scratch);
  ASSERT_GT(daemon.port(), 0);
  GrpcFrames grpc(daemon.address());
  ASSERT_TRUE(WaitUntil([&] { return grpc.size() > 0; }, absl::Seconds(30)));

  const std::string out = scratch.File("frames.bin");
  const ProcessResult reader =
      RunReader({"live", daemon.uri(), "8", out, absl::StrCat(kWidth, "x", kHeight), "mm"});
  ASSERT_EQ(reader.exit_code, 0) << reader.err;
  // The sensor is an ideal pinhole (the simulator's): its own size passes unchanged, and its
  // fields of view give its focal length back.
  const v1::CameraInfo& camera = grpc.info().camera();
  EXPECT_NEAR(std::stod(Printed(reader.out, "hfov")), 2 * std::atan(kWidth / (2 * camera.fx())),
              1e-6);
  EXPECT_NEAR(std::stod(Printed(reader.out, "vfov")), 2 * std::atan(kHeight / (2 * camera.fy())),
              1e-6);
  EXPECT_EQ(Printed(reader.out, "registration"), "1");
  EXPECT_EQ(std::stoi(Printed(reader.out, "max")),
            static_cast<int>(std::ceil(grpc.info().unambiguous_range_m() * 1000 - 1e-9)));

  const std::vector<ReaderFrame> frames = ReadFrames(out);
  ASSERT_EQ(frames.size(), 8u);
  uint64_t previous_timestamp = 0;
  for (const ReaderFrame& frame : frames) {
    ASSERT_EQ(frame.width, kWidth);
    ASSERT_EQ(frame.format, openni::PIXEL_FORMAT_DEPTH_1_MM);
    ASSERT_TRUE(WaitUntil([&] { return grpc.Has(frame.index); }, absl::Seconds(10)))
        << "frame " << frame.index << " never came over gRPC";
    const GrpcFrames::Frame expected = grpc.Get(frame.index);
    EXPECT_EQ(frame.pixels, expected.depth_mm) << "frame " << frame.index;
    EXPECT_GT(CountNonZero(frame.pixels), kWidth * kHeight / 2) << "the scene has depth";
    EXPECT_GT(frame.timestamp_us, previous_timestamp) << "timestamps increase";
    previous_timestamp = frame.timestamp_us;
  }
}

// A daemon that requires a token (docs/security.md): an OpenNI2 program finds no device without
// TRANSIENT_OPENNI2_TOKEN_FILE, and reads depth with it.
TEST(OpenNi2Driver, ADaemonWithATokenIsOpenedWithTheTokenFileOfTheEnvironment) {
  ScratchDirectory scratch;
  const std::string token = scratch.File("token");
  std::ofstream(token) << "0123456789abcdef0123456789abcdef\n";
  std::filesystem::permissions(token, std::filesystem::perms::owner_read |
                                          std::filesystem::perms::owner_write);
  Daemon daemon(scratch, 0, {"--token-file", token});
  ASSERT_GT(daemon.port(), 0);
  const std::string out = scratch.File("frames.bin");
  const std::vector<std::string> args = {"live", daemon.uri(), "2", out,
                                         absl::StrCat(kWidth, "x", kHeight), "mm"};
  unsetenv("TRANSIENT_OPENNI2_TOKEN_FILE");
  const ProcessResult refused = RunReader(args);
  EXPECT_NE(refused.exit_code, 0) << refused.out;
  setenv("TRANSIENT_OPENNI2_TOKEN_FILE", token.c_str(), 1);
  const ProcessResult reader = RunReader(args);
  unsetenv("TRANSIENT_OPENNI2_TOKEN_FILE");
  ASSERT_EQ(reader.exit_code, 0) << reader.err;
  const std::vector<ReaderFrame> frames = ReadFrames(out);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_GT(CountNonZero(frames[0].pixels), kWidth * kHeight / 2) << "the scene has depth";
}

TEST(OpenNi2Driver, ARecordingOfTheDevicePlaysBackEveryRecordedFrame) {
  ScratchDirectory scratch;
  Daemon daemon(scratch);
  ASSERT_GT(daemon.port(), 0);
  GrpcFrames grpc(daemon.address());
  ASSERT_TRUE(WaitUntil([&] { return grpc.size() > 0; }, absl::Seconds(30)));

  const std::string oni = scratch.File("capture.oni");
  // The device's default mode (640 x 480, what applications ask for), recorded by OpenNI2.
  const ProcessResult record = RunReader({"record", daemon.uri(), "6", oni});
  ASSERT_EQ(record.exit_code, 0) << record.err;
  const std::string played = scratch.File("played.bin");
  const ProcessResult play = RunReader({"play", oni, played});
  ASSERT_EQ(play.exit_code, 0) << play.err;
  const int recorded = std::stoi(Printed(play.out, "frames"));
  EXPECT_GE(recorded, 4) << "OpenNI2's recorder may miss the frames around start and stop";
  // The recording keeps the stream's properties (without CROPPING it would play nothing).
  const double hfov = std::stod(Printed(play.out, "hfov"));
  EXPECT_NEAR(hfov, 2 * std::atan(kWidth / (2 * grpc.info().camera().fx())), 1e-6);

  const std::vector<ReaderFrame> frames = ReadFrames(played);
  ASSERT_EQ(static_cast<int>(frames.size()), recorded) << "every recorded frame plays back";
  const std::vector<GrpcFrames::Frame> sent = grpc.All();
  for (const ReaderFrame& frame : frames) {
    ASSERT_EQ(frame.width, 640);
    ASSERT_EQ(frame.height, 480);
    // Playback renumbers frames: find the daemon's frame it was by content.
    bool found = false;
    for (const GrpcFrames::Frame& candidate : sent) {
      bool same = true;
      for (int v = 0; v < 480 && same; v += 7) {
        for (int u = 0; u < 640 && same; u += 5) {
          same = frame.pixels[v * 640 + u] ==
                 ExpectedResampled(candidate, grpc.info().camera(), 640, 480, hfov, u, v);
        }
      }
      found |= same;
    }
    EXPECT_TRUE(found) << "played frame " << frame.index << " is no frame the daemon sent";
  }
}

// --- In this process, through OpenNI2's API ----------------------------------------------------

// OpenNI2 initialised in this process with the driver pointed at `address`.
class OpenNi {
 public:
  explicit OpenNi(const std::string& address) {
    setenv("TRANSIENT_OPENNI2_ADDRESS", address.c_str(), 1);
    status_ = openni::OpenNI::initialize();
  }
  // No OpenNI::shutdown(): see openni_only_reader.cc.
  bool ok() const { return status_ == openni::STATUS_OK; }
  static std::vector<std::string> DeviceUris() {
    openni::Array<openni::DeviceInfo> devices;
    openni::OpenNI::enumerateDevices(&devices);
    std::vector<std::string> uris;
    for (int i = 0; i < devices.getSize(); ++i) uris.push_back(devices[i].getUri());
    return uris;
  }

 private:
  openni::Status status_ = openni::STATUS_ERROR;
};

// The next frame of `stream` within 10 s.
bool NextFrame(openni::VideoStream& stream, openni::VideoFrameRef* frame, int timeout_ms = 10000) {
  openni::VideoStream* streams[] = {&stream};
  int ready = -1;
  return openni::OpenNI::waitForAnyStream(streams, 1, &ready, timeout_ms) == openni::STATUS_OK &&
         stream.readFrame(frame) == openni::STATUS_OK;
}

std::vector<uint16_t> Pixels(const openni::VideoFrameRef& frame) {
  const auto* data = static_cast<const uint16_t*>(frame.getData());
  return {data, data + static_cast<size_t>(frame.getWidth()) * frame.getHeight()};
}

// transientd on the simulator, its frames over gRPC, and OpenNI2 in this process with the driver
// pointed at it: what a device's frames are compared with.
class OpenNi2DriverFrames : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_GT(daemon_.port(), 0);
    ASSERT_TRUE(openni_.ok()) << openni::OpenNI::getExtendedError();
  }
  // The daemon's frame of `index` (over gRPC); empty, with a failure, when it never came.
  GrpcFrames::Frame Sent(uint64_t index) {
    if (!WaitUntil([&] { return grpc_.Has(index); }, absl::Seconds(10))) {
      ADD_FAILURE() << "frame " << index << " never came over gRPC";
      return {};
    }
    return grpc_.Get(index);
  }

  ScratchDirectory scratch_;
  Daemon daemon_{scratch_};
  GrpcFrames grpc_{daemon_.address()};
  OpenNi openni_{daemon_.address()};
};

TEST(OpenNi2Driver, AnnouncesTheDefaultDaemonAndAnswersPropertiesOfEitherIntegerSize) {
  ScratchDirectory scratch;
  Daemon daemon(scratch);
  ASSERT_GT(daemon.port(), 0);
  OpenNi openni(daemon.address());
  ASSERT_TRUE(openni.ok()) << openni::OpenNI::getExtendedError();
  EXPECT_THAT(OpenNi::DeviceUris(), ::testing::Contains(daemon.uri()));

  openni::Device device;
  ASSERT_EQ(device.open(openni::ANY_DEVICE), openni::STATUS_OK);
  EXPECT_EQ(std::string(device.getDeviceInfo().getUri()), daemon.uri());
  char serial[64] = {};
  int size = sizeof serial;
  ASSERT_EQ(device.getProperty(openni::DEVICE_PROPERTY_SERIAL_NUMBER, serial, &size),
            openni::STATUS_OK);
  EXPECT_GT(std::string(serial).size(), 0u);
  EXPECT_TRUE(device.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR));
  EXPECT_EQ(device.setImageRegistrationMode(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR),
            openni::STATUS_OK);
  int unknown = 0;
  size = sizeof unknown;
  EXPECT_NE(device.getProperty(0x7777, &unknown, &size), openni::STATUS_OK);

  openni::VideoStream depth;
  ASSERT_EQ(depth.create(device, openni::SENSOR_DEPTH), openni::STATUS_OK);
  const openni::VideoMode mode = depth.getVideoMode();
  EXPECT_EQ(mode.getResolutionX(), 640);
  EXPECT_EQ(mode.getResolutionY(), 480);
  EXPECT_EQ(mode.getFps(), 30);
  EXPECT_EQ(mode.getPixelFormat(), openni::PIXEL_FORMAT_DEPTH_1_MM);
  bool native = false;
  const openni::Array<openni::VideoMode>& modes = depth.getSensorInfo().getSupportedVideoModes();
  for (int i = 0; i < modes.getSize(); ++i) {
    native |= modes[i].getResolutionX() == kWidth && modes[i].getResolutionY() == kHeight &&
              modes[i].getPixelFormat() == openni::PIXEL_FORMAT_DEPTH_100_UM;
  }
  EXPECT_TRUE(native) << "the sensor's own size in 100 um";

  // Integers as 4 or 8 bytes (OpenCV reads the zero plane distance into an int), reals as
  // float or double; any other size is refused, not overrun.
  int32_t zpd32 = 0;
  int64_t zpd64 = 0;
  EXPECT_EQ(depth.getProperty(XN_STREAM_PROPERTY_ZERO_PLANE_DISTANCE, &zpd32), openni::STATUS_OK);
  EXPECT_EQ(depth.getProperty(XN_STREAM_PROPERTY_ZERO_PLANE_DISTANCE, &zpd64), openni::STATUS_OK);
  EXPECT_EQ(zpd32, 120);
  EXPECT_EQ(zpd64, 120);
  int32_t max32 = 0;
  int64_t max64 = 0;
  EXPECT_EQ(depth.getProperty(openni::STREAM_PROPERTY_MAX_VALUE, &max32), openni::STATUS_OK);
  EXPECT_EQ(depth.getProperty(openni::STREAM_PROPERTY_MAX_VALUE, &max64), openni::STATUS_OK);
  EXPECT_EQ(max32, max64);
  EXPECT_GT(max32, 0);
  EXPECT_LT(max32, 0xFFFF);
  double pixel_size = 0;
  ASSERT_EQ(depth.getProperty(XN_STREAM_PROPERTY_ZERO_PLANE_PIXEL_SIZE, &pixel_size),
            openni::STATUS_OK);
  const float hfov = depth.getHorizontalFieldOfView();
  EXPECT_NEAR(120 / (2 * pixel_size), 640 / (2 * std::tan(hfov / 2)), 1e-3)
      << "OpenCV's focal length from the zero plane equals the one from the field of view";
  float hfov_as_float = 0;
  double hfov_as_double = 0;
  EXPECT_EQ(depth.getProperty(openni::STREAM_PROPERTY_HORIZONTAL_FOV, &hfov_as_float),
            openni::STATUS_OK);
  EXPECT_EQ(depth.getProperty(openni::STREAM_PROPERTY_HORIZONTAL_FOV, &hfov_as_double),
            openni::STATUS_OK);
  EXPECT_FLOAT_EQ(static_cast<float>(hfov_as_double), hfov_as_float);
  int16_t too_small = 0;
  EXPECT_NE(depth.getProperty(openni::STREAM_PROPERTY_MAX_VALUE, &too_small), openni::STATUS_OK);
  EXPECT_NE(depth.getProperty(0x7777, &zpd32), openni::STATUS_OK) << "an unknown property";
  EXPECT_FALSE(depth.isPropertySupported(0x7777));
  EXPECT_TRUE(depth.isPropertySupported(openni::STREAM_PROPERTY_CROPPING));
  int crop_x = -1, crop_y = -1, crop_width = 0, crop_height = 0;
  EXPECT_FALSE(depth.getCropping(&crop_x, &crop_y, &crop_width, &crop_height)) << "not cropped";
  EXPECT_EQ(depth.setMirroringEnabled(false), openni::STATUS_OK);
  openni::VideoMode absent = mode;
  absent.setResolution(123, 45);
  EXPECT_NE(depth.setVideoMode(absent), openni::STATUS_OK) << "a mode the sensor does not offer";

  // Bad keys and values of a device URI: refused, though the daemon answers.
  for (const char* query : {"?unit=cm", "?size=0x480", "?size=big", "?ir_scale=-1",
                            "?ir_scale=x", "?colour=red", "?unit"}) {
    openni::Device bad;
    EXPECT_NE(bad.open(absl::StrCat(daemon.uri(), query).c_str()), openni::STATUS_OK) << query;
  }

  // A size the URI asks for is one more mode, and the streams' first.
  openni::Device sized;
  ASSERT_EQ(sized.open(absl::StrCat(daemon.uri(), "?size=400x300").c_str()), openni::STATUS_OK);
  openni::VideoStream sized_depth;
  ASSERT_EQ(sized_depth.create(sized, openni::SENSOR_DEPTH), openni::STATUS_OK);
  EXPECT_EQ(sized_depth.getVideoMode().getResolutionX(), 400);
  EXPECT_EQ(sized_depth.getVideoMode().getResolutionY(), 300);
  EXPECT_EQ(sized_depth.getSensorInfo().getSupportedVideoModes().getSize(), modes.getSize() + 2)
      << "in mm and in 100 um";
}

TEST_F(OpenNi2DriverFrames, VgaIsTheIdealPinholeOfItsFieldOfView) {
  openni::Device device;
  ASSERT_EQ(device.open(daemon_.uri().c_str()), openni::STATUS_OK);
  openni::VideoStream depth;
  ASSERT_EQ(depth.create(device, openni::SENSOR_DEPTH), openni::STATUS_OK);
  ASSERT_EQ(depth.start(), openni::STATUS_OK);
  openni::VideoFrameRef frame;
  ASSERT_TRUE(NextFrame(depth, &frame));
  ASSERT_EQ(frame.getWidth(), 640);
  const GrpcFrames::Frame sent = Sent(frame.getFrameIndex());
  ASSERT_FALSE(sent.depth_mm.empty());
  const double hfov = depth.getHorizontalFieldOfView();
  const std::vector<uint16_t> pixels = Pixels(frame);
  int mismatches = 0, with_depth = 0;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      const uint16_t expected = ExpectedResampled(sent, grpc_.info().camera(), 640, 480, hfov, u, v);
      mismatches += pixels[v * 640 + u] != expected;
      with_depth += expected != 0;
    }
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(with_depth, 640 * 480 / 2);
  // OpenNI2's own converter (principal point at the image's edge-based centre w/2) puts the
  // point of the pixel right of the centre at x = Z * 0.5 / f: the same focal length.
  const int u = 320, v = 240;
  const uint16_t z = pixels[v * 640 + u];
  ASSERT_GT(z, 0);
  float x = 0, y = 0, world_z = 0;
  ASSERT_EQ(openni::CoordinateConverter::convertDepthToWorld(depth, u, v, z, &x, &y, &world_z),
            openni::STATUS_OK);
  const double f = 640 / (2 * std::tan(hfov / 2));
  EXPECT_NEAR(world_z, z, 1e-3);
  EXPECT_NEAR(x, z * (u - 320.0) / f, 0.01);
  EXPECT_NEAR(-y, z * (v - 240.0) / (depth.getVideoMode().getResolutionY() /
                                     (2 * std::tan(depth.getVerticalFieldOfView() / 2))),
              0.01);
  EXPECT_NEAR(640 / (2 * std::tan(hfov / 2)),
              480 / (2 * std::tan(depth.getVerticalFieldOfView() / 2)), 1e-3)
      << "fx = fy";
  depth.stop();
}

TEST_F(OpenNi2DriverFrames, HundredMicrometresMirroringAndIrShareTheCapture) {
  openni::Device device;
  ASSERT_EQ(device.open(absl::StrCat(daemon_.uri(), "?size=native&unit=100um").c_str()),
            openni::STATUS_OK);
  openni::VideoStream depth, ir;
  ASSERT_EQ(depth.create(device, openni::SENSOR_DEPTH), openni::STATUS_OK);
  ASSERT_EQ(ir.create(device, openni::SENSOR_IR), openni::STATUS_OK);
  EXPECT_EQ(depth.getVideoMode().getPixelFormat(), openni::PIXEL_FORMAT_DEPTH_100_UM);
  EXPECT_EQ(ir.getVideoMode().getPixelFormat(), openni::PIXEL_FORMAT_GRAY16);
  EXPECT_EQ(device.setDepthColorSyncEnabled(true), openni::STATUS_OK);
  ASSERT_EQ(depth.setMirroringEnabled(true), openni::STATUS_OK);
  ASSERT_EQ(depth.start(), openni::STATUS_OK);
  ASSERT_EQ(ir.start(), openni::STATUS_OK);

  openni::VideoFrameRef depth_frame, ir_frame;
  ASSERT_TRUE(NextFrame(depth, &depth_frame));
  ASSERT_TRUE(NextFrame(ir, &ir_frame));
  // The IR frame of the same capture: same index, same timestamp.
  for (int tries = 0; tries < 40 && ir_frame.getFrameIndex() != depth_frame.getFrameIndex();
       ++tries) {
    if (ir_frame.getFrameIndex() < depth_frame.getFrameIndex()) {
      ASSERT_TRUE(NextFrame(ir, &ir_frame));
    } else {
      ASSERT_TRUE(NextFrame(depth, &depth_frame));
    }
  }
  ASSERT_EQ(ir_frame.getFrameIndex(), depth_frame.getFrameIndex());
  EXPECT_EQ(ir_frame.getTimestamp(), depth_frame.getTimestamp());
  const GrpcFrames::Frame sent = Sent(depth_frame.getFrameIndex());
  ASSERT_FALSE(sent.depth_mm.empty());
  const std::vector<uint16_t> depth_pixels = Pixels(depth_frame), ir_pixels = Pixels(ir_frame);
  ASSERT_EQ(depth_pixels.size(), static_cast<size_t>(kWidth * kHeight));
  int compared = 0;
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u) {
      const size_t pixel = static_cast<size_t>(v) * kWidth + u;
      // Mirrored: column u shows the sensor's column W-1-u. In 100 um, a tenth of the mm value
      // rounds to it (each is the depth rounded to its unit).
      const uint16_t hundred_um = depth_pixels[static_cast<size_t>(v) * kWidth + (kWidth - 1 - u)];
      if (sent.depth_mm[pixel] == 0) {
        EXPECT_EQ(hundred_um, 0) << u << "," << v;
        continue;
      }
      EXPECT_NEAR(hundred_um / 10.0, sent.depth_mm[pixel], 0.55) << u << "," << v;
      EXPECT_EQ(ir_pixels[pixel], openni2::IrCount(sent.amplitude[pixel], 1.0)) << u << "," << v;
      ++compared;
    }
  }
  EXPECT_GT(compared, kWidth * kHeight / 2);
  ir.stop();
  depth.stop();
}

TEST_F(OpenNi2DriverFrames, TheColourStreamIsTheAmplitudeInGrey) {
  openni::Device device;
  ASSERT_EQ(device.open(absl::StrCat(daemon_.uri(), "?size=native").c_str()), openni::STATUS_OK);
  ASSERT_NE(device.getSensorInfo(openni::SENSOR_COLOR), nullptr);
  openni::VideoStream colour;
  ASSERT_EQ(colour.create(device, openni::SENSOR_COLOR), openni::STATUS_OK);
  EXPECT_EQ(colour.getVideoMode().getPixelFormat(), openni::PIXEL_FORMAT_RGB888);
  EXPECT_EQ(colour.getMaxPixelValue(), 255);
  ASSERT_EQ(colour.start(), openni::STATUS_OK);
  openni::VideoFrameRef frame;
  ASSERT_TRUE(NextFrame(colour, &frame));
  ASSERT_EQ(frame.getWidth(), kWidth);
  EXPECT_EQ(frame.getStrideInBytes(), 3 * kWidth);
  const GrpcFrames::Frame sent = Sent(frame.getFrameIndex());
  ASSERT_FALSE(sent.amplitude.empty());
  const auto* rgb = static_cast<const uint8_t*>(frame.getData());
  int lit = 0;
  for (size_t pixel = 0; pixel < sent.amplitude.size(); ++pixel) {
    const uint8_t grey = openni2::GreyLevel(sent.amplitude[pixel], 1.0);
    ASSERT_EQ(rgb[3 * pixel], grey) << pixel;
    ASSERT_EQ(rgb[3 * pixel + 1], grey) << pixel;
    ASSERT_EQ(rgb[3 * pixel + 2], grey) << pixel;
    lit += grey > 0;
  }
  EXPECT_GT(lit, kWidth * kHeight / 2);
  colour.stop();
}

TEST(OpenNi2Driver, WithoutADaemonInitializeIsQuickAndAnnouncesNothing) {
  // A port nobody listens on: bind one and close it.
  ScratchDirectory scratch;
  int closed_port = 0;
  {
    Daemon probe(scratch);
    closed_port = probe.port();
    probe.Kill();
  }
  ASSERT_GT(closed_port, 0);
  const std::string address = absl::StrCat("127.0.0.1:", closed_port);
  const absl::Time start = absl::Now();
  OpenNi openni(address);
  const absl::Duration took = absl::Now() - start;
  ASSERT_TRUE(openni.ok()) << openni::OpenNI::getExtendedError();
  // Generous for a loaded machine; the driver's own bound is 0.2 s.
  EXPECT_LT(took, absl::Seconds(3)) << "OpenNI2's initialize waited for a daemon";
  for (const std::string& uri : OpenNi::DeviceUris()) {
    EXPECT_THAT(uri, ::testing::Not(HasSubstr("transient://")));
  }
  openni::Device device;
  EXPECT_NE(device.open(absl::StrCat("transient://", address).c_str()), openni::STATUS_OK);
  EXPECT_NE(device.open("transient://"), openni::STATUS_OK) << "no address";
  EXPECT_NE(device.open("transient://127.0.0.1:1?colour=red"), openni::STATUS_OK);
  EXPECT_NE(device.open("elsewhere://camera"), openni::STATUS_OK) << "another driver's URI";
  EXPECT_NE(device.open(scratch.File("no-such.oni").c_str()), openni::STATUS_OK);
}

TEST(OpenNi2Driver, InsideTransientdTheDriverStaysSilent) {
  ScratchDirectory scratch;
  Daemon daemon(scratch);
  ASSERT_GT(daemon.port(), 0);
  setenv("TRANSIENT_OPENNI2_DISABLE", "1", 1);
  OpenNi openni(daemon.address());
  ASSERT_TRUE(openni.ok()) << openni::OpenNI::getExtendedError();
  EXPECT_THAT(OpenNi::DeviceUris(), ::testing::Not(::testing::Contains(daemon.uri())));
  openni::Device device;
  EXPECT_NE(device.open(daemon.uri().c_str()), openni::STATUS_OK);
  unsetenv("TRANSIENT_OPENNI2_DISABLE");
}

// Counts the device's state changes that OpenNI2 reports.
class StateListener : public openni::OpenNI::DeviceStateChangedListener {
 public:
  void onDeviceStateChanged(const openni::DeviceInfo*, openni::DeviceState state) override {
    (state == openni::DEVICE_STATE_OK ? ok_ : errors_)++;
  }
  int errors() const { return errors_; }
  int oks() const { return ok_; }

 private:
  std::atomic<int> errors_{0}, ok_{0};
};

TEST(OpenNi2Driver, ADaemonThatStopsEndsTheStreamAndTheDeviceComesBackWithIt) {
  ScratchDirectory scratch;
  auto daemon = std::make_unique<Daemon>(scratch);
  const int port = daemon->port();
  ASSERT_GT(port, 0);
  OpenNi openni(daemon->address());
  ASSERT_TRUE(openni.ok()) << openni::OpenNI::getExtendedError();
  StateListener states;
  openni::OpenNI::addDeviceStateChangedListener(&states);
  openni::Device device;
  ASSERT_EQ(device.open(daemon->uri().c_str()), openni::STATUS_OK);
  openni::VideoStream depth;
  ASSERT_EQ(depth.create(device, openni::SENSOR_DEPTH), openni::STATUS_OK);
  ASSERT_EQ(depth.start(), openni::STATUS_OK);
  openni::VideoFrameRef frame;
  ASSERT_TRUE(NextFrame(depth, &frame));

  daemon->Kill();
  ASSERT_TRUE(WaitUntil([&] { return states.errors() > 0; }, absl::Seconds(10)))
      << "the device reported no error state";
  // No frame while the daemon is gone (the last one may still be in flight).
  NextFrame(depth, &frame, 200);
  EXPECT_FALSE(NextFrame(depth, &frame, 500));
  const uint64_t before = frame.getTimestamp();

  daemon = std::make_unique<Daemon>(scratch, port);
  ASSERT_EQ(daemon->port(), port);
  ASSERT_TRUE(NextFrame(depth, &frame, 20000)) << "no frame after the daemon came back";
  EXPECT_GT(frame.getTimestamp(), before) << "the device's clock stays monotonic";
  EXPECT_TRUE(WaitUntil([&] { return states.oks() > 0; }, absl::Seconds(5)));
  depth.stop();
  depth.destroy();
  device.close();
  openni::OpenNI::removeDeviceStateChangedListener(&states);
}

}  // namespace
}  // namespace transient
