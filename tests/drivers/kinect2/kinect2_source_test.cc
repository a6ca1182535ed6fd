// usb:kinect2 on the emulated Kinect v2 (emulated_kinect2.h) through Debian's real libusb: the
// open and start sequences, the frames and their metadata, the factory calibration, the stream
// faults the camera injects (the libfreenect2 iso-offset regression among them), the command
// faults, unplugging, stopping with transfers in flight, a USB 2 port, a wrong serial, the
// device listing and the queue that drops the oldest frame.
#include "kinect2/kinect2_source.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <map>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "kinect2/kinect2_format.h"
#include "tests/drivers/kinect2/emulated_kinect2.h"
#include "tests/support/status_matchers.h"
#include "transient/drivers/capture_devices.h"
#include "transient/drivers/capture_source.h"

namespace transient::kinect2 {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;
namespace emu = ::transient::kinect2::testing;

// A sample that says where it is: sub-frame s of frame n at pixel (x, y). Multiples of 64 up to
// 16,320 are on the companding grid (its coarsest step), so they come back exactly.
float Sample(uint32_t n, int s, int x, int y) {
  const int m = ((static_cast<int>(n % 7) * 10 + s) * 2 + (x + y) % 2) - 70;
  return static_cast<float>(64 * m);
}

emu::Renderer Pattern() {
  return [](uint32_t n, int s, std::span<float> v) {
    for (int y = 0; y < 424; ++y) {
      for (int x = 0; x < 512; ++x) v[y * 512 + x] = Sample(n, s, x, y);
    }
  };
}

class Kinect2SourceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(emu::EmulatedKinect2::Available())
        << "run under LD_PRELOAD=libumockdev-preload.so.0 (ctest does)";
  }
  void Emulate(emu::Options options) {
    absl::StatusOr<std::unique_ptr<emu::EmulatedKinect2>> created =
        emu::EmulatedKinect2::Create(std::move(options));
    ASSERT_THAT(created.status(), IsOk());
    camera_ = *std::move(created);
  }
  static emu::Options Defaults() {
    emu::Options o;
    o.renderer = Pattern();
    return o;
  }
  std::unique_ptr<emu::EmulatedKinect2> camera_;
};

// The nine correlation sub-frames of the next depth frame.
std::vector<RawFrame> NextFrame(CaptureSource& source) {
  std::vector<RawFrame> frames(9);
  for (RawFrame& f : frames) {
    const absl::Status status = source.Next(absl::Seconds(10), &f);
    EXPECT_THAT(status, IsOk());
    if (!status.ok()) return {};
  }
  return frames;
}

// The emulated frame number (mod 7) a delivered frame came from, from its samples.
int FrameOf(const RawFrame& f) {
  const int m = static_cast<int>(std::lround(f.pixels[10 * 512 + 5] / 64.0f)) + 70;  // x + y odd
  return ((m - 1) / 2) / 10;
}

std::map<std::string, int64_t> CountersOf(const CaptureSource& source) {
  std::map<std::string, int64_t> out;
  for (const SourceCounter& c : source.Counters()) out[c.name] = c.value;
  return out;
}

TEST_F(Kinect2SourceTest, OpensStartsAndDeliversEachSubFrameWithItsFooterTime) {
  emu::Options o = Defaults();
  o.p0_tables[1].assign(512 * 424, 0);
  o.p0_tables[1][100 * 512 + 200] = 5000;  // group 1: 16 MHz, harmonic 2
  o.intrinsics.fx = 366.5f;
  o.first_timestamp = 4000;
  Emulate(std::move(o));
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource("usb:kinect2");
  ASSERT_THAT(source.status(), IsOk());
  CaptureSource& s = **source;
  EXPECT_EQ(s.camera().geometry, (ImageGeometry{512, 424}));
  EXPECT_DOUBLE_EQ(s.camera().intrinsics.fx, 366.5);
  EXPECT_THAT(s.camera().model, HasSubstr("serial 501234543042, firmware 4.0.3912.0"));
  EXPECT_EQ(s.schedule().raw_frames_per_frame(), 9);
  // The factory calibration: P0 value v is the phase factor exp(+i * v * 0.000031 * pi).
  std::string origin;
  const CalibrationTable* table = s.embedded_calibration(&origin);
  ASSERT_NE(table, nullptr);
  EXPECT_THAT(origin, HasSubstr("P0 tables of Kinect v2 serial 501234543042"));
  const size_t q = 2 * 512 * 424 + 100 * 512 + 200;
  EXPECT_NEAR(std::arg(std::complex<double>(table->real[q], table->imag[q])),
              std::remainder(5000 * 0.000031 * 3.14159265358979, 2 * 3.14159265358979), 1e-5);

  ASSERT_THAT(s.Start(), IsOk());
  for (int n = 0; n < 2; ++n) {
    const std::vector<RawFrame> frames = NextFrame(s);
    ASSERT_EQ(frames.size(), 9u);
    for (int k = 0; k < 9; ++k) {
      const RawFrame& f = frames[static_cast<size_t>(k)];
      const ExposureConfig want = SubFrameExposure(k);
      EXPECT_EQ(f.config.harmonic, want.harmonic);
      EXPECT_DOUBLE_EQ(f.config.phase_shift_rad, want.phase_shift_rad);
      EXPECT_EQ(f.config.cycle, n);
      EXPECT_EQ(f.config.sequence, static_cast<uint64_t>(10 * n + k));
      // Its own footer's time: frame n * 266 + k * 26 ticks of 125 us after the first.
      EXPECT_NEAR(f.config.timestamp_s, (266 * n + 26 * k) * 125e-6, 1e-9);
      EXPECT_TRUE(std::isnan(f.pixels[7 * 512]));  // dead columns
      EXPECT_TRUE(std::isnan(f.pixels[7 * 512 + 511]));
      for (int y : {0, 100, 211, 212, 300, 423}) {
        for (int x : {1, 2, 3, 4, 5, 130, 255, 510}) {
          ASSERT_EQ(f.pixels[y * 512 + x], Sample(static_cast<uint32_t>(n), k, x, y))
              << n << " " << k << " " << x << " " << y;
        }
      }
    }
  }
  ASSERT_THAT(s.Stop(), IsOk());
  const emu::Counters c = camera_->counters();
  EXPECT_EQ(c.interface1_alt_setting, 0);
  EXPECT_FALSE(c.streaming);
  EXPECT_EQ(c.iso_urbs_pending, 0);
  EXPECT_GT(c.urbs_discarded, 0);  // stopped with transfers in flight: all came back
  std::vector<uint32_t> commands;
  for (const emu::ReceivedCommand& r : camera_->Commands()) {
    if (commands.empty() || commands.back() != r.command || r.command != emu::kReadStatus) {
      commands.push_back(r.command);
    }
  }
  EXPECT_THAT(commands, ::testing::ElementsAre(
                            emu::kReadFirmwareVersions, emu::kReadData, emu::kReadData,
                            emu::kReadData, emu::kSetMode, emu::kSetMode, emu::kReadStatus,
                            emu::kInitStreams, emu::kSetStreaming, emu::kStop,
                            emu::kSetStreaming));
  const std::map<std::string, int64_t> counters = CountersOf(s);
  EXPECT_GE(counters.at("frames"), 2);
  EXPECT_EQ(counters.at("iso_packet_errors"), 0);
  EXPECT_EQ(counters.at("frames_incomplete"), 0);
}

// The emulated frame numbers of the next `count` depth frames of the camera with `fault`,
// each sub-frame checked to belong to its frame and to carry its samples; `source` receives the
// opened source for its counters.
std::vector<int> FramesWithFault(const emu::Fault& fault, int count,
                                 std::unique_ptr<CaptureSource>* source,
                                 std::unique_ptr<emu::EmulatedKinect2>* camera) {
  emu::Options o;
  o.renderer = Pattern();
  o.faults.push_back(fault);
  absl::StatusOr<std::unique_ptr<emu::EmulatedKinect2>> created =
      emu::EmulatedKinect2::Create(std::move(o));
  EXPECT_THAT(created.status(), IsOk());
  if (!created.ok()) return {};
  *camera = *std::move(created);
  absl::StatusOr<std::unique_ptr<CaptureSource>> opened = OpenSource("usb:kinect2");
  EXPECT_THAT(opened.status(), IsOk());
  if (!opened.ok() || !(*opened)->Start().ok()) return {};
  *source = *std::move(opened);
  std::vector<int> delivered;
  for (int n = 0; n < count; ++n) {
    const std::vector<RawFrame> frames = NextFrame(**source);
    if (frames.size() != 9) return delivered;
    delivered.push_back(FrameOf(frames[0]));
    for (int k = 0; k < 9; ++k) {
      const RawFrame& f = frames[static_cast<size_t>(k)];
      EXPECT_EQ(FrameOf(f), delivered.back()) << k;
      for (auto [x, y] : {std::pair{77, 300}, std::pair{9, 50}}) {
        EXPECT_EQ(f.pixels[y * 512 + x], Sample(static_cast<uint32_t>(delivered.back()), k, x, y))
            << k << " " << x << " " << y;
      }
    }
  }
  return delivered;
}

// The libfreenect2 regression: a failed iso packet in the middle of a transfer. The packets
// after it in the same transfer carry their own bytes at their own offsets; only the sub-frame
// of the failed packet is lost.
TEST_F(Kinect2SourceTest, AFailedIsoPacketLosesOneSubFrameAndTheRestOfItsTransferIsRight) {
  std::unique_ptr<CaptureSource> source;
  EXPECT_THAT(FramesWithFault(emu::Fault::AtPacket(emu::Fault::kPacketError, 1, 3, 4), 3, &source,
                              &camera_),
              ::testing::ElementsAre(0, 2, 3));  // frame 1 lost sub-frame 3
  ASSERT_NE(source, nullptr);
  const std::map<std::string, int64_t> counters = CountersOf(*source);
  EXPECT_EQ(counters.at("iso_packet_errors"), 1);
  EXPECT_EQ(counters.at("subpackets_lost"), 1);
  EXPECT_EQ(counters.at("bad_footers"), 0);  // no sub-frame read from a shifted offset
  EXPECT_EQ(counters.at("subpackets_short"), 0);
  EXPECT_EQ(counters.at("frames_incomplete"), 1);
}

struct StreamFaultCase {
  const char* name;
  emu::Fault fault;
  const char* counter;
};
void PrintTo(const StreamFaultCase& c, std::ostream* os) { *os << c.name; }

class StreamFaultTest : public Kinect2SourceTest,
                        public ::testing::WithParamInterface<StreamFaultCase> {};

TEST_P(StreamFaultTest, DropsTheFrameCountsWhyAndTheNextFramesAreRight) {
  std::unique_ptr<CaptureSource> source;
  EXPECT_THAT(FramesWithFault(GetParam().fault, 3, &source, &camera_),
              ::testing::ElementsAre(0, 2, 3));
  ASSERT_NE(source, nullptr);
  const std::map<std::string, int64_t> counters = CountersOf(*source);
  // A short or zero-length packet in the middle of a sub-frame cuts it in two pieces, each
  // ending before it is whole.
  const int64_t expected = std::string(GetParam().counter) == "subpackets_short" ? 2 : 1;
  EXPECT_EQ(counters.at(GetParam().counter), expected) << GetParam().counter;
  EXPECT_EQ(counters.at("frames_incomplete"), 1);
}

INSTANTIATE_TEST_SUITE_P(
    Faults, StreamFaultTest,
    ::testing::Values(
        StreamFaultCase{"ShortPacket", emu::Fault::AtPacket(emu::Fault::kShortPacket, 1, 5, 2),
                        "subpackets_short"},
        StreamFaultCase{"ZeroLengthPacket",
                        emu::Fault::AtPacket(emu::Fault::kZeroLengthPacket, 1, 0, 6),
                        "subpackets_short"},
        StreamFaultCase{"LostSubPacket",
                        emu::Fault::AtSubFrame(emu::Fault::kLostSubPacket, 1, 8),
                        "frames_incomplete"},
        StreamFaultCase{"WrongFooter",
                        emu::Fault::AtSubFrame(emu::Fault::kWrongFooterLength, 1, 2, 1234),
                        "bad_footers"}),
    [](const ::testing::TestParamInfo<StreamFaultCase>& info) { return info.param.name; });

TEST_F(Kinect2SourceTest, CommandFaultsAtOpenAreClearErrors) {
  struct Case {
    emu::Fault fault;
    absl::StatusCode code;
    const char* message;
  };
  // One emulated camera per process: the cases run one after another on it, each fault at a
  // later occurrence of its command.
  emu::Options o = Defaults();
  o.faults = {
      emu::Fault::AtCommand(emu::Fault::kCommandTimeout, emu::kReadData, 0),
      emu::Fault::AtCommand(emu::Fault::kWrongSequence, emu::kReadFirmwareVersions, 1),
  };
  Emulate(std::move(o));
  absl::StatusOr<std::unique_ptr<CaptureSource>> timeout =
      OpenSource("usb:kinect2?command_timeout_ms=200");
  EXPECT_THAT(timeout.status(),
              StatusIs(absl::StatusCode::kUnavailable,
                       HasSubstr("Kinect v2 serial 501234543042: no answer to the response to "
                                 "command read data (0x22) within 200ms")));
  absl::StatusOr<std::unique_ptr<CaptureSource>> sequence = OpenSource("usb:kinect2");
  EXPECT_THAT(sequence.status(),
              StatusIs(absl::StatusCode::kDataLoss,
                       HasSubstr("command firmware versions (0x02): response complete for "
                                 "sequence")));
  // The camera still answers the next open.
  EXPECT_THAT(OpenSource("usb:kinect2").status(), IsOk());
}

TEST_F(Kinect2SourceTest, ACameraThatNeverGetsReadyIsAClearError) {
  emu::Options o = Defaults();
  o.status_ready_after_polls = emu::Options::kNever;
  Emulate(std::move(o));
  absl::StatusOr<std::unique_ptr<CaptureSource>> source =
      OpenSource("usb:kinect2?ready_timeout_ms=300");
  ASSERT_THAT(source.status(), IsOk());
  EXPECT_THAT((*source)->Start(), StatusIs(absl::StatusCode::kUnavailable,
                                           HasSubstr("is not ready to stream after 300ms")));
}

TEST_F(Kinect2SourceTest, UnpluggedWhileStreamingIsUnavailableAndStopsCleanly) {
  emu::Options o = Defaults();
  o.faults.push_back(emu::Fault::AtSubFrame(emu::Fault::kUnplugStreaming, 2, 4));
  Emulate(std::move(o));
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource("usb:kinect2");
  ASSERT_THAT(source.status(), IsOk());
  ASSERT_THAT((*source)->Start(), IsOk());
  absl::Status status;
  RawFrame frame;
  int frames = 0;
  for (int i = 0; i < 100 && status.ok(); ++i) {
    status = (*source)->Next(absl::Seconds(10), &frame);
    frames += status.ok();
  }
  EXPECT_EQ(frames, 18);  // frames 0 and 1
  EXPECT_THAT(status, StatusIs(absl::StatusCode::kUnavailable, HasSubstr("was unplugged")));
  EXPECT_THAT((*source)->Stop(), IsOk());
  EXPECT_TRUE(camera_->counters().unplugged);
}

TEST_F(Kinect2SourceTest, UnpluggedDuringStartIsUnavailable) {
  emu::Options o = Defaults();
  o.faults.push_back(emu::Fault::AtCommand(emu::Fault::kUnplugAtCommand, emu::kInitStreams));
  Emulate(std::move(o));
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource("usb:kinect2");
  ASSERT_THAT(source.status(), IsOk());
  EXPECT_THAT((*source)->Start(), StatusIs(absl::StatusCode::kUnavailable,
                                           HasSubstr("was unplugged (sending command init "
                                                     "streams (0x09))")));
  EXPECT_THAT(OpenSource("usb:kinect2").status(),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("no Kinect v2")));
}

TEST_F(Kinect2SourceTest, StopsWithTransfersInFlightAndStartsAgain) {
  Emulate(Defaults());
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource("usb:kinect2");
  ASSERT_THAT(source.status(), IsOk());
  for (int round = 0; round < 3; ++round) {
    ASSERT_THAT((*source)->Start(), IsOk());
    EXPECT_EQ(NextFrame(**source).size(), 9u);
    ASSERT_THAT((*source)->Stop(), IsOk());
    const emu::Counters c = camera_->counters();
    EXPECT_EQ(c.iso_urbs_pending, 0) << round;
    EXPECT_FALSE(c.streaming);
  }
  EXPECT_GE(camera_->counters().urbs_discarded, 3);
}

TEST_F(Kinect2SourceTest, AUsb2PortAndAWrongSerialAreRefusedSayingWhy) {
  emu::Options o = Defaults();
  o.speed_mbps = 480;
  Emulate(std::move(o));
  EXPECT_THAT(OpenSource("usb:kinect2").status(),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("is on a USB 2 port (480 Mbit/s); it needs USB 3")));
  EXPECT_THAT(OpenSource("usb:kinect2?serial=123").status(),
              StatusIs(absl::StatusCode::kNotFound,
                       HasSubstr("no Kinect v2 with serial 123; found: serial 501234543042 at "
                                 "bus 001 device 002")));
  const std::vector<CaptureDevice> devices =
      ListCaptureDevices({.dev_dir = "/nonexistent", .openni2 = false});
  ASSERT_EQ(devices.size(), 1u);
  EXPECT_EQ(devices[0].uri, "usb:kinect2?serial=501234543042");
  EXPECT_FALSE(devices[0].usable);
  EXPECT_THAT(devices[0].details, ::testing::Contains(HasSubstr("480 Mbit/s")));
  EXPECT_THAT(OpenSource("usb:kinect2?queue=0").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("queue = '0'")));
  EXPECT_THAT(OpenSource("usb:kinect2?fps=30").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("unknown key 'fps'")));
}

TEST_F(Kinect2SourceTest, AConsumerThatFallsBehindLosesTheOldestFramesCounted) {
  Emulate(Defaults());
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource("usb:kinect2?queue=2");
  ASSERT_THAT(source.status(), IsOk());
  ASSERT_THAT((*source)->Start(), IsOk());
  // The camera streams as fast as it is reaped; nobody takes frames for a while.
  while (CountersOf(**source).at("frames") < 6) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const std::map<std::string, int64_t> counters = CountersOf(**source);
  EXPECT_GE(counters.at("frames_dropped_queue"), 4);
  const std::vector<RawFrame> frames = NextFrame(**source);
  ASSERT_EQ(frames.size(), 9u);
  EXPECT_GE(frames[0].config.cycle, 4);  // the newest ones are kept
}

}  // namespace
}  // namespace transient::kinect2
