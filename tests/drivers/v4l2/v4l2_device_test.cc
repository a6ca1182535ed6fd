// The V4L2 device node and `transient devices` through the real open/stat/ioctl path, on nodes
// that umockdev emulates in this process (emulated_tof_sensor.h): capabilities, formats, the
// ToF controls by enumeration, and the nodes that are not what we need.
#include "v4l2/v4l2_device.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <linux/videodev2.h>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "tests/drivers/v4l2/emulated_tof_sensor.h"
#include "tests/support/status_matchers.h"
#include "tests/support/subprocess.h"
#include "transient/drivers/capture_devices.h"
#include "v4l2/frame_unpacker.h"

namespace transient::v4l2 {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::Not;
using ::transient::testing::IsOk;
using ::transient::testing::IsOkAndHolds;
using ::transient::testing::StatusIs;
using testing::EmulatedNode;
using testing::EmulatedTofSensor;

// The emulated nodes only: OpenNI2's USB drivers would look at umockdev's emulated system too.
const DeviceListOptions kWithoutOpenNi2{.openni2 = false};

EmulatedNode Mlx75027() {
  EmulatedNode node;
  node.formats = {{kFourccY12P, "12-bit Greyscale (MIPI Packed)"}, {kFourccY12, "12-bit Greyscale"}};
  node.controls = testing::Mlx7502xControls();
  return node;
}

class V4l2DeviceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // Not a skip: without the preload library the emulation is missing, and ctest sets it.
    ASSERT_TRUE(EmulatedTofSensor::Available())
        << "run under LD_PRELOAD=libumockdev-preload.so.0 (ctest does)";
  }
  EmulatedTofSensor sensor_;
};

TEST_F(V4l2DeviceTest, CapabilitiesFormatsAndControlsComeFromTheNode) {
  sensor_.AddNode(Mlx75027());
  absl::StatusOr<V4l2Device> device = V4l2Device::Open("/dev/video0");
  ASSERT_THAT(device.status(), IsOk());
  absl::StatusOr<Capabilities> caps = device->QueryCapabilities();
  ASSERT_THAT(caps.status(), IsOk());
  EXPECT_EQ(caps->driver, "mlx7502x");
  EXPECT_EQ(caps->card, "MLX75027 ToF");
  EXPECT_TRUE(caps->capture());
  EXPECT_TRUE(caps->streaming());
  absl::StatusOr<std::vector<PixelFormatDescription>> formats = device->EnumerateFormats();
  ASSERT_THAT(formats.status(), IsOk());
  ASSERT_EQ(formats->size(), 2u);
  EXPECT_EQ((*formats)[0].fourcc, kFourccY12P);
  EXPECT_EQ((*formats)[1].description, "12-bit Greyscale");
  absl::StatusOr<std::vector<ControlDescription>> controls = device->EnumerateControls();
  ASSERT_THAT(controls.status(), IsOk());
  ASSERT_EQ(controls->size(), 6u);
  const ControlDescription& phases = (*controls)[3];
  EXPECT_EQ(phases.id, kTofPhaseSequence.id);
  EXPECT_EQ(phases.name, "TOF Phase Sequence");
  EXPECT_TRUE(phases.dynamic_array());
  EXPECT_EQ(phases.elements, 8u);
  EXPECT_EQ(DescribeControlRange(phases), "u16[<=8] 0..315 step 45");
  EXPECT_TRUE(IsTofControl(phases));
  EXPECT_FALSE(IsTofControl((*controls)[0]));  // the driver's output mode
  EXPECT_EQ(DescribeControlRange((*controls)[1]), "button");
}

const ControlDescription& ControlNamed(const std::vector<ControlDescription>& controls,
                                       const std::string& name) {
  for (const ControlDescription& c : controls) {
    if (c.name == name) return c;
  }
  throw std::runtime_error("no control " + name);
}

TEST_F(V4l2DeviceTest, ControlsAreSetAllOrNothingAndReadBackAsTheDriverRoundedThem) {
  EmulatedNode node = Mlx75027();
  node.refuse_control = kTofTimeIntegration.id;
  sensor_.AddNode(node);
  absl::StatusOr<V4l2Device> device = V4l2Device::Open("/dev/video0");
  ASSERT_THAT(device.status(), IsOk());
  absl::StatusOr<std::vector<ControlDescription>> controls = device->EnumerateControls();
  ASSERT_THAT(controls.status(), IsOk());
  const ControlDescription& frequency = ControlNamed(*controls, "TOF Frequency Modulation");
  const ControlDescription& phases = ControlNamed(*controls, "TOF Phase Sequence");
  const ControlDescription& integration = ControlNamed(*controls, "TOF Time Integration");
  const ControlDescription& trigger = ControlNamed(*controls, "Camera Trigger");
  // The core rounds integer elements to the step (1 MHz) and clamps them to the range.
  const ControlValue set[] = {{&frequency, {23'400'000}}, {&phases, {0, 90, 180, 270}}};
  ASSERT_THAT(device->SetControls(set), IsOk());
  const ControlDescription* both[] = {&frequency, &phases};
  absl::StatusOr<std::vector<std::vector<int64_t>>> got = device->GetControls(both);
  ASSERT_THAT(got.status(), IsOk());
  EXPECT_THAT(*got, ElementsAre(ElementsAre(23'000'000), ElementsAre(0, 90, 180, 270)));
  const ControlValue too_high[] = {{&frequency, {250'000'000}}};
  ASSERT_THAT(device->SetControls(too_high), IsOk());
  EXPECT_THAT(device->GetControl(frequency), IsOkAndHolds(ElementsAre(100'000'000)));
  // All or nothing: the refused integration time leaves the frequency as it was.
  const ControlValue refused[] = {{&frequency, {40'000'000}}, {&integration, {500, 500}}};
  EXPECT_THAT(device->SetControls(refused),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("'TOF Time Integration' = 500,500"), HasSubstr("refused"))));
  EXPECT_THAT(device->GetControl(frequency), IsOkAndHolds(ElementsAre(100'000'000)));
  // More elements than the array holds never reach the driver; a button cannot be read.
  const ControlValue nine[] = {{&phases, std::vector<int64_t>(9, 0)}};
  EXPECT_THAT(device->SetControls(nine),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("holds 1 to 8 elements")));
  EXPECT_THAT(device->GetControl(trigger).status(),
              StatusIs(absl::StatusCode::kInternal, HasSubstr("'Camera Trigger'")));
}

TEST_F(V4l2DeviceTest, ControlEventsTellOfChangesByOthers) {
  sensor_.AddNode(Mlx75027());
  absl::StatusOr<V4l2Device> device = V4l2Device::Open("/dev/video0");
  ASSERT_THAT(device.status(), IsOk());
  const uint32_t ids[] = {kTofFrequencyModulation.id, kTofPhaseSequence.id};
  ASSERT_THAT(device->SubscribeControlEvents(ids), IsOk());
  EXPECT_THAT(device->ChangedControls(), IsOkAndHolds(IsEmpty()));
  sensor_.SetControl("video0", kTofFrequencyModulation.id, {30'000'000});
  sensor_.SetControl("video0", kTofTimeIntegration.id, {100});  // not subscribed
  sensor_.SetControl("video0", kTofPhaseSequence.id, {0, 180});
  EXPECT_THAT(device->ChangedControls(),
              IsOkAndHolds(ElementsAre(kTofFrequencyModulation.id, kTofPhaseSequence.id)));
  EXPECT_THAT(device->ChangedControls(), IsOkAndHolds(IsEmpty()));
  // A driver without control events says so.
  EmulatedNode silent = Mlx75027();
  silent.name = "video1";
  silent.events = false;
  sensor_.AddNode(silent);
  absl::StatusOr<V4l2Device> other = V4l2Device::Open("/dev/video1");
  ASSERT_THAT(other.status(), IsOk());
  EXPECT_THAT(other->SubscribeControlEvents(ids),
              StatusIs(absl::StatusCode::kUnimplemented, HasSubstr("no control events")));
}

TEST_F(V4l2DeviceTest, ToFControlsUnderOtherIdsAreFoundByName) {
  // An earlier patch version: the same controls as driver-private IDs.
  EmulatedNode node = Mlx75027();
  for (ControlDescription& control : node.controls) {
    if (control.id >= kTofControlClass) control.id = control.id - kTofControlClass + 0x00981000;
  }
  std::sort(node.controls.begin(), node.controls.end(),
            [](const auto& a, const auto& b) { return a.id < b.id; });
  sensor_.AddNode(node);
  absl::StatusOr<V4l2Device> device = V4l2Device::Open("/dev/video0");
  ASSERT_THAT(device.status(), IsOk());
  absl::StatusOr<std::vector<ControlDescription>> controls = device->EnumerateControls();
  ASSERT_THAT(controls.status(), IsOk());
  int tof = 0;
  for (const ControlDescription& control : *controls) tof += IsTofControl(control) ? 1 : 0;
  EXPECT_EQ(tof, 5);
}

TEST_F(V4l2DeviceTest, DevicesListsTheNodeWithItsFormatsAndToFControls) {
  sensor_.AddNode(Mlx75027());
  EmulatedNode other = Mlx75027();
  other.name = "video1";
  other.card = "YUYV webcam";
  other.formats = {{v4l2::Fourcc('Y', 'U', 'Y', 'V'), "YUYV 4:2:2"}};
  other.controls = {};
  sensor_.AddNode(other);
  const std::vector<CaptureDevice> devices = ListCaptureDevices(kWithoutOpenNi2);
  ASSERT_EQ(devices.size(), 2u);
  EXPECT_EQ(devices[0].uri, "v4l2:/dev/video0");
  EXPECT_EQ(devices[0].name, "MLX75027 ToF");
  EXPECT_TRUE(devices[0].usable);
  EXPECT_FALSE(devices[1].usable);
  const std::string text = DescribeCaptureDevices(devices, kWithoutOpenNi2);
  EXPECT_THAT(text, AllOf(HasSubstr("v4l2:/dev/video0  MLX75027 ToF\n"),
                          HasSubstr("raw formats we read: Y12P, Y12"),
                          HasSubstr("ToF control 0x00a60901 \"TOF Frequency Modulation\": "
                                    "u32[<=1] 4000000..100000000 step 1000000"),
                          HasSubstr("v4l2:/dev/video1  YUYV webcam  (not usable)"),
                          HasSubstr("raw formats we read: none; others: YUYV"),
                          HasSubstr("no ToF controls on this node (0 controls)")));
}

// The transient program itself, a child process: umockdev's preload library (inherited with the
// environment) hands its ioctls to this process's emulated sensor.
TEST_F(V4l2DeviceTest, TheTransientProgramListsTheEmulatedNode) {
  sensor_.AddNode(Mlx75027());
  const ::transient::testing::ProcessResult result =
      ::transient::testing::RunProcess({TRANSIENT_BINARY, "devices", "--no-openni2"});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_THAT(result.out, AllOf(HasSubstr("v4l2:/dev/video0  MLX75027 ToF\n"),
                                HasSubstr("raw formats we read: Y12P, Y12"),
                                HasSubstr("\"TOF Phase Sequence\": u16[<=8] 0..315 step 45")));
}

TEST_F(V4l2DeviceTest, NodesThatAreNotCaptureDevicesSayWhy) {
  EmulatedNode metadata = Mlx75027();
  metadata.device_caps = V4L2_CAP_META_CAPTURE | V4L2_CAP_STREAMING;
  sensor_.AddNode(metadata);
  EmulatedNode broken = Mlx75027();
  broken.name = "video2";
  broken.querycap_errno = ENOTTY;
  sensor_.AddNode(broken);
  const std::vector<CaptureDevice> devices = ListCaptureDevices(kWithoutOpenNi2);
  ASSERT_EQ(devices.size(), 2u);
  EXPECT_FALSE(devices[0].usable);
  EXPECT_THAT(devices[0].details, ::testing::Contains(HasSubstr("not a streaming video capture")));
  EXPECT_FALSE(devices[1].usable);
  EXPECT_THAT(devices[1].details,
              ElementsAre(AllOf(HasSubstr("/dev/video2: VIDIOC_QUERYCAP"),
                                HasSubstr("not a V4L2 node"))));
  absl::StatusOr<V4l2Device> device = V4l2Device::Open("/dev/video2");
  ASSERT_THAT(device.status(), IsOk());
  EXPECT_THAT(device->QueryCapabilities().status(),
              StatusIs(absl::StatusCode::kFailedPrecondition, HasSubstr("/dev/video2")));
}

TEST_F(V4l2DeviceTest, MissingNodesAreNotFoundAndAnEmptyListSaysSo) {
  EXPECT_THAT(V4l2Device::Open("/dev/video7").status(),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("/dev/video7")));
  const std::vector<CaptureDevice> devices = ListCaptureDevices(kWithoutOpenNi2);
  EXPECT_THAT(devices, IsEmpty());
  EXPECT_EQ(DescribeCaptureDevices(devices, kWithoutOpenNi2),
            "no capture devices found (looked for V4L2 nodes /dev/videoN and Kinect v2 "
            "cameras on USB)\n");
}

EmulatedNode SmallSensor() {
  EmulatedNode node = Mlx75027();
  node.sensor = {8, 4};
  return node;
}

// Four rows of eight 12-bit samples, value 100 * row + column + offset, packed as MIPI RAW12
// with `padding` bytes of 0xee after each row (the kernel's Y12P layout, research §2.2).
std::vector<uint8_t> PackedFrame(size_t padding, int offset = 0) {
  std::vector<int32_t> samples;
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 8; ++x) samples.push_back(100 * y + x + offset);
  }
  std::vector<uint8_t> bytes = testing::PackSamples(kFourccY12P, {8, 4}, 12 + padding, 12, samples);
  for (size_t y = 0; y < 4; ++y) {
    std::fill_n(bytes.begin() + static_cast<std::ptrdiff_t>(y * (12 + padding) + 12), padding, 0xee);
  }
  return bytes;
}

TEST_F(V4l2DeviceTest, AFormatTheDriverAdjustsIsRefusedNamingBoth) {
  sensor_.AddNode(SmallSensor());
  absl::StatusOr<V4l2Device> device = V4l2Device::Open("/dev/video0");
  ASSERT_THAT(device.status(), IsOk());
  EXPECT_THAT(device->SetFormat(kFourccY12P, {16, 4}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("asked for Y12P 16x4, the driver granted Y12P 8x4")));
  EXPECT_THAT(device->SetFormat(kFourccY16, {8, 4}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("asked for Y16 8x4, the driver granted Y12P 8x4")));
  absl::StatusOr<NegotiatedFormat> format = device->SetFormat(kFourccY12, {8, 4});
  ASSERT_THAT(format.status(), IsOk());
  EXPECT_EQ(format->bytes_per_line, 16u);
  EXPECT_EQ(format->image_bytes, 64u);
}

TEST_F(V4l2DeviceTest, StreamedBuffersAreReadThroughTheMappingWithTheDriversMetadata) {
  EmulatedNode node = SmallSensor();
  node.row_padding = 4;  // bytesperline 16 for 12 bytes of samples
  sensor_.AddNode(node);
  absl::StatusOr<V4l2Device> device = V4l2Device::Open("/dev/video0");
  ASSERT_THAT(device.status(), IsOk());
  absl::StatusOr<NegotiatedFormat> format = device->SetFormat(kFourccY12P, {8, 4});
  ASSERT_THAT(format.status(), IsOk());
  EXPECT_EQ(format->bytes_per_line, 16u);
  ASSERT_THAT(device->StartStreaming(6, 5), IsOk());
  sensor_.PushFrame("video0", {.bytes = PackedFrame(4), .timestamp_ns = 1'500'000'000});
  sensor_.PushFrame("video0", {.bytes = PackedFrame(4, 1), .frames_lost_before = 2,
                               .timestamp_ns = 1'533'000'000});
  sensor_.PushFrame("video0", {.bytes = PackedFrame(4), .error_flag = true});
  sensor_.PushFrame("video0", {.bytes = std::vector<uint8_t>(10, 0)});  // a short transfer

  absl::StatusOr<DequeuedFrame> first = device->Dequeue(absl::Seconds(5));
  ASSERT_THAT(first.status(), IsOk());
  EXPECT_EQ(first->buffer.sequence, 0u);
  EXPECT_EQ(first->buffer.timestamp_ns, 1'500'000'000);
  EXPECT_FALSE(first->buffer.error_flag);
  EXPECT_EQ(first->buffer.bytes_used, 64u);
  std::vector<float> pixels(32);
  const FrameLayout layout{.geometry = {8, 4}, .bytes_per_line = format->bytes_per_line};
  ASSERT_THAT(Unpack(first->data, layout, {.fourcc = kFourccY12P}, pixels), IsOk());
  EXPECT_EQ(pixels[0], 0);
  EXPECT_EQ(pixels[9], 101);
  EXPECT_EQ(pixels[31], 307);
  ASSERT_THAT(device->Requeue(first->index), IsOk());

  absl::StatusOr<DequeuedFrame> second = device->Dequeue(absl::Seconds(5));
  ASSERT_THAT(second.status(), IsOk());
  EXPECT_EQ(second->buffer.sequence, 3u);  // two frames lost before it, counted by the driver
  ASSERT_THAT(Unpack(second->data, layout, {.fourcc = kFourccY12P}, pixels), IsOk());
  EXPECT_EQ(pixels[31], 308);
  absl::StatusOr<DequeuedFrame> third = device->Dequeue(absl::Seconds(5));
  ASSERT_THAT(third.status(), IsOk());
  EXPECT_TRUE(third->buffer.error_flag);
  absl::StatusOr<DequeuedFrame> fourth = device->Dequeue(absl::Seconds(5));
  ASSERT_THAT(fourth.status(), IsOk());
  EXPECT_EQ(fourth->buffer.bytes_used, 10u);
  EXPECT_THAT(Unpack(fourth->data, layout, {.fourcc = kFourccY12P}, pixels),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("short buffer: 10 bytes")));
  EXPECT_THAT(device->StopStreaming(), IsOk());
}

TEST_F(V4l2DeviceTest, NothingToDequeueIsDeadlineExceededAndUnplugIsUnavailable) {
  sensor_.AddNode(SmallSensor());
  absl::StatusOr<V4l2Device> device = V4l2Device::Open("/dev/video0");
  ASSERT_THAT(device.status(), IsOk());
  ASSERT_THAT(device->SetFormat(kFourccY12P, {8, 4}).status(), IsOk());
  ASSERT_THAT(device->StartStreaming(4, 4), IsOk());
  EXPECT_THAT(device->Dequeue(absl::Milliseconds(30)).status(),
              StatusIs(absl::StatusCode::kDeadlineExceeded, HasSubstr("no buffer within 30ms")));
  sensor_.PushFrame("video0", {.bytes = PackedFrame(0)});
  sensor_.Unplug("video0");
  EXPECT_THAT(device->Dequeue(absl::Seconds(5)).status(),
              StatusIs(absl::StatusCode::kUnavailable, HasSubstr("device gone")));
  EXPECT_THAT(device->StopStreaming(), IsOk());  // STREAMOFF on a gone device is not an error
}

TEST_F(V4l2DeviceTest, TooFewBuffersOrNoFormatAreRefused) {
  EmulatedNode node = SmallSensor();
  node.max_buffers = 3;
  sensor_.AddNode(node);
  absl::StatusOr<V4l2Device> device = V4l2Device::Open("/dev/video0");
  ASSERT_THAT(device.status(), IsOk());
  EXPECT_THAT(device->StartStreaming(6, 5),
              StatusIs(absl::StatusCode::kFailedPrecondition, HasSubstr("no format set")));
  ASSERT_THAT(device->SetFormat(kFourccY12P, {8, 4}).status(), IsOk());
  EXPECT_THAT(device->StartStreaming(6, 5),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("granted 3 buffers, 5 are needed")));
  EXPECT_FALSE(device->streaming());
  EXPECT_THAT(device->Dequeue(absl::Milliseconds(1)).status(),
              StatusIs(absl::StatusCode::kFailedPrecondition, HasSubstr("not streaming")));
}

}  // namespace
}  // namespace transient::v4l2
