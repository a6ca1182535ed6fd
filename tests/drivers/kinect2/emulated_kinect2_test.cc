// The emulated Kinect v2 (emulated_kinect2.h) seen through Debian's libusb, as the code under
// test will see it: enumeration and descriptors, the command protocol, the depth stream in
// concurrent iso transfers, its faults, cancellation and unplugs. The sub-images are read back
// with a decoder of this file's own, written from research §1.4.
#include "tests/drivers/kinect2/emulated_kinect2.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <libusb.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "tests/support/status_matchers.h"

namespace transient::kinect2::testing {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

constexpr uint16_t kMicrosoft = 0x045e;
constexpr uint16_t kKinect2 = 0x02d8;
constexpr unsigned int kTimeoutMs = 1000;  // libfreenect2's command timeout

uint32_t U32(const uint8_t* at) {
  return static_cast<uint32_t>(at[0]) | static_cast<uint32_t>(at[1]) << 8 |
         static_cast<uint32_t>(at[2]) << 16 | static_cast<uint32_t>(at[3]) << 24;
}
float F32(const uint8_t* at) {
  const uint32_t bits = U32(at);
  float value;
  std::memcpy(&value, &bits, sizeof(value));
  return value;
}

// The 11-bit code of column x of output row r in a sub-image, read bit by bit as research §1.4
// lays it out: rows read out from the middle, 4 interleaved groups of 128 columns, codes
// packed least significant bit first.
uint16_t CodeAt(const uint8_t* image, int x, int r) {
  const int row = r < 212 ? r : 635 - r;
  const uint8_t* bytes = image + static_cast<size_t>(row) * 704;
  const int slot = (x >> 2) + ((x & 3) << 7);
  uint16_t code = 0;
  for (int b = 0; b < 11; ++b) {
    const int at = 11 * slot + b;
    if ((bytes[at >> 3] >> (at & 7)) & 1) code = static_cast<uint16_t>(code | (1 << b));
  }
  return code;
}

// The value a code stands for (research §1.4's table): sign bit 1024, companded magnitude;
// 1024 itself is saturation.
int CodeValue(uint16_t code) {
  if (code == 1024) return 32767;
  const int magnitude_code = code & 1023;
  int magnitude = magnitude_code;
  if (magnitude_code >= 256) {
    const int range = (magnitude_code - 256) / 128;
    const int step = (magnitude_code - 256) % 128;
    magnitude = (256 << range) + step * (2 << range);
  }
  return (code & 1024) != 0 ? -magnitude : magnitude;
}

// Representable test values that differ by pixel, sub-frame and frame: small signed ones, and
// every seventh column one of the coarsest range.
float TestSample(uint32_t sequence, int subframe, int x, int r) {
  if (x % 7 == 0) return static_cast<float>(8192 + 64 * ((x + r + subframe) % 128));
  return static_cast<float>((x + 3 * r + 7 * subframe + 11 * static_cast<int>(sequence)) % 200 -
                            100);
}

void RenderTestSubFrame(uint32_t sequence, int subframe, std::span<float> samples) {
  for (int r = 0; r < kHeight; ++r) {
    for (int x = 0; x < kWidth; ++x) {
      samples[static_cast<size_t>(r) * kWidth + x] = TestSample(sequence, subframe, x, r);
    }
  }
}

std::vector<float> TestSubFrame(uint32_t sequence, int subframe) {
  std::vector<float> samples(static_cast<size_t>(kWidth) * kHeight);
  RenderTestSubFrame(sequence, subframe, samples);
  return samples;
}

struct SubPacket {
  uint32_t timestamp = 0, sequence = 0, subsequence = 0, length = 0;
  std::vector<uint8_t> image;  // kept on request
};

// Frames the stream by byte count alone, as research §1.3 describes: a zero-length packet
// starts over, a sub-packet is complete at 298,648 bytes (the last 152 its footer), more is
// an overflow; a packet with an error status loses its bytes.
class Reassembler {
 public:
  explicit Reassembler(bool keep_images) : keep_images_(keep_images) {}

  void Add(int status, const uint8_t* data, unsigned int length) {
    if (status != LIBUSB_TRANSFER_COMPLETED) {
      ++error_packets;
      return;
    }
    if (length == 0) {
      if (!buffer_.empty()) ++incomplete;
      buffer_.clear();
      return;
    }
    if (buffer_.size() + length > kSubPacketBytes) {
      ++overflows;
      buffer_.clear();
      return;
    }
    buffer_.insert(buffer_.end(), data, data + length);
    if (buffer_.size() < kSubPacketBytes) return;
    const uint8_t* footer = buffer_.data() + kSubImageBytes;
    SubPacket sub;
    sub.timestamp = U32(footer + 8);
    sub.sequence = U32(footer + 12);
    sub.subsequence = U32(footer + 16);
    sub.length = U32(footer + 20);
    if (keep_images_) sub.image.assign(buffer_.begin(), buffer_.begin() + kSubImageBytes);
    subpackets.push_back(std::move(sub));
    buffer_.clear();
  }

  std::vector<SubPacket> subpackets;
  int error_packets = 0;
  int incomplete = 0;  // sub-packets cut short by a zero-length packet
  int overflows = 0;

 private:
  bool keep_images_;
  std::vector<uint8_t> buffer_;
};

// Concurrent iso transfers on 0x84, resubmitted from their callbacks until `stop` says so.
class IsoStream {
 public:
  IsoStream(libusb_context* context, libusb_device_handle* handle, int transfers, int packets,
            bool keep_images)
      : reassembler(keep_images), context_(context) {
    for (int i = 0; i < transfers; ++i) {
      libusb_transfer* transfer = libusb_alloc_transfer(packets);
      buffers_.emplace_back(static_cast<size_t>(packets) * kMaxIsoPacketBytes);
      libusb_fill_iso_transfer(transfer, handle, 0x84, buffers_.back().data(),
                               static_cast<int>(buffers_.back().size()), packets, &Callback, this,
                               0);
      libusb_set_iso_packet_lengths(transfer, static_cast<unsigned int>(kMaxIsoPacketBytes));
      transfers_.push_back(transfer);
    }
  }
  // A test that failed half-way may leave transfers in flight: they end before they are freed.
  ~IsoStream() {
    stop = [] { return true; };
    CancelAll();
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (active > 0 && std::chrono::steady_clock::now() < deadline) {
      timeval tv{0, 1000};
      libusb_handle_events_timeout_completed(context_, &tv, nullptr);
    }
    for (libusb_transfer* transfer : transfers_) libusb_free_transfer(transfer);
  }

  int Submit() {
    for (libusb_transfer* transfer : transfers_) {
      const int result = libusb_submit_transfer(transfer);
      if (result != 0) return result;
      ++active;
    }
    return 0;
  }
  void CancelAll() {
    for (libusb_transfer* transfer : transfers_) libusb_cancel_transfer(transfer);
  }

  std::function<bool()> stop = [] { return false; };
  std::function<void(libusb_transfer*)> observe;  // every completed transfer
  Reassembler reassembler;
  int active = 0;
  std::vector<int> statuses;        // of the completed transfers, in order
  std::vector<int> submit_results;  // of the failed resubmissions
  int64_t bytes = 0;

 private:
  static void Callback(libusb_transfer* transfer) {
    static_cast<IsoStream*>(transfer->user_data)->Completed(transfer);
  }
  void Completed(libusb_transfer* transfer) {
    --active;
    statuses.push_back(transfer->status);
    if (observe) observe(transfer);
    // An unplug ends the transfer being filled with NO_DEVICE after the packets already in it.
    if (transfer->status == LIBUSB_TRANSFER_COMPLETED ||
        transfer->status == LIBUSB_TRANSFER_NO_DEVICE) {
      for (int i = 0; i < transfer->num_iso_packets; ++i) {
        const libusb_iso_packet_descriptor& packet = transfer->iso_packet_desc[i];
        bytes += packet.actual_length;
        reassembler.Add(packet.status, libusb_get_iso_packet_buffer(transfer, i),
                        packet.actual_length);
      }
    }
    if (transfer->status != LIBUSB_TRANSFER_COMPLETED || stop()) return;
    const int result = libusb_submit_transfer(transfer);
    if (result == 0) {
      ++active;
    } else {
      submit_results.push_back(result);
    }
  }

  libusb_context* context_;
  std::vector<std::vector<uint8_t>> buffers_;
  std::vector<libusb_transfer*> transfers_;
};

struct Reply {
  int sent = 0;         // libusb result of the command's bulk OUT
  int data_result = 0;  // of the response read (when asked for)
  std::vector<uint8_t> data;
  int complete_result = 0;  // of the "complete" read
  std::vector<uint8_t> complete;
};

class EmulatedKinect2Test : public ::testing::Test {
 protected:
  void SetUp() override {
    // Not a skip: without the preload library the emulation is missing, and ctest sets it.
    ASSERT_TRUE(EmulatedKinect2::Available())
        << "run under LD_PRELOAD=libumockdev-preload.so.0 (ctest does)";
  }
  void TearDown() override {
    if (handle_ != nullptr) libusb_close(handle_);
    if (context_ != nullptr) libusb_exit(context_);
    kinect_.reset();  // after libusb_exit
  }

  // The device first, then libusb (the header says why).
  void Start(Options options = {}) {
    absl::StatusOr<std::unique_ptr<EmulatedKinect2>> kinect =
        EmulatedKinect2::Create(std::move(options));
    ASSERT_THAT(kinect.status(), IsOk());
    kinect_ = std::move(*kinect);
    ASSERT_EQ(libusb_init(&context_), 0);
  }

  // Opens the device, configuration 1, both interfaces claimed (research §1.2's start).
  void Open(uint16_t product_id = kKinect2) {
    handle_ = libusb_open_device_with_vid_pid(context_, kMicrosoft, product_id);
    ASSERT_NE(handle_, nullptr);
    ASSERT_EQ(libusb_set_configuration(handle_, 1), 0);
    ASSERT_EQ(libusb_claim_interface(handle_, 0), 0);
    ASSERT_EQ(libusb_claim_interface(handle_, 1), 0);
  }

  // The depth stream on: interface 1 at alt 1, then 0x2B(1).
  void StartStreaming() {
    ASSERT_EQ(libusb_set_interface_alt_setting(handle_, 1, 1), 0);
    const Reply reply = Command(kSetStreaming, 0, {1});
    ASSERT_EQ(reply.complete_result, 0);
    ASSERT_TRUE(kinect_->counters().streaming);
  }

  // One command round trip as research §1.2 describes the host's side.
  Reply Command(uint32_t command, uint32_t max_response_length, std::vector<uint32_t> params,
                unsigned int timeout_ms = kTimeoutMs) {
    std::vector<uint32_t> words = {kCommandMagic, ++sequence_, max_response_length, command, 0};
    words.insert(words.end(), params.begin(), params.end());
    std::vector<uint8_t> bytes(words.size() * 4);
    for (size_t i = 0; i < words.size(); ++i) {
      for (int b = 0; b < 4; ++b) bytes[4 * i + b] = static_cast<uint8_t>(words[i] >> (8 * b));
    }
    Reply reply;
    int transferred = 0;
    reply.sent = libusb_bulk_transfer(handle_, 0x02, bytes.data(), static_cast<int>(bytes.size()),
                                      &transferred, timeout_ms);
    if (reply.sent != 0) return reply;
    if (max_response_length > 0) {
      reply.data.resize(max_response_length);
      reply.data_result =
          libusb_bulk_transfer(handle_, 0x81, reply.data.data(),
                               static_cast<int>(max_response_length), &transferred, timeout_ms);
      reply.data.resize(static_cast<size_t>(transferred));
      if (reply.data_result != 0) return reply;
    }
    reply.complete.resize(512);
    reply.complete_result =
        libusb_bulk_transfer(handle_, 0x81, reply.complete.data(), 512, &transferred, timeout_ms);
    reply.complete.resize(static_cast<size_t>(transferred));
    return reply;
  }

  // Runs libusb's event handling until `done` (false after 10 s).
  bool HandleEventsUntil(const std::function<bool()>& done) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (!done()) {
      if (std::chrono::steady_clock::now() > deadline) return false;
      timeval tv{0, 1000};
      libusb_handle_events_timeout_completed(context_, &tv, nullptr);
    }
    return true;
  }

  // Streams until `subpackets` sub-packets are assembled (or the stream stops), then lets the
  // transfers in flight complete.
  void Stream(IsoStream& stream, size_t subpackets) {
    stream.stop = [&stream, subpackets] {
      return stream.reassembler.subpackets.size() >= subpackets;
    };
    ASSERT_EQ(stream.Submit(), 0);
    ASSERT_TRUE(HandleEventsUntil([&stream] { return stream.active == 0; }))
        << stream.reassembler.subpackets.size() << " sub-packets";
  }

  std::unique_ptr<EmulatedKinect2> kinect_;
  libusb_context* context_ = nullptr;
  libusb_device_handle* handle_ = nullptr;
  uint32_t sequence_ = 0;
};

TEST(EncodeSample, EveryCodeComesBackFromTheValueItStandsFor) {
  for (int code = 0; code < 2048; ++code) {
    if (code == 1024) continue;  // saturation: no value of its own
    EXPECT_EQ(EncodeSample(static_cast<float>(CodeValue(static_cast<uint16_t>(code)))), code)
        << CodeValue(static_cast<uint16_t>(code));
  }
}

TEST(EncodeSample, ValuesBetweenCodesGoToTheNearest) {
  EXPECT_EQ(EncodeSample(254.6f), 255);
  EXPECT_EQ(EncodeSample(258.9f), 257);     // 258 (code 257) is nearer than 260
  EXPECT_EQ(EncodeSample(1022.5f), 512);    // 1024, the first of the step-8 range
  EXPECT_EQ(EncodeSample(16340.0f), 1023);  // 16,320, the largest magnitude
  EXPECT_EQ(EncodeSample(-3.2f), 1024 + 3);
  EXPECT_EQ(EncodeSample(-0.4f), 0);  // no negative zero: 1024 would mean saturated
}

TEST(EncodeSample, NaNIsZeroAndOutOfRangeIsSaturated) {
  EXPECT_EQ(EncodeSample(std::numeric_limits<float>::quiet_NaN()), 0);
  EXPECT_EQ(EncodeSample(16353.0f), kSaturationCode);
  EXPECT_EQ(EncodeSample(-20000.0f), kSaturationCode);
  EXPECT_EQ(EncodeSample(32767.0f), kSaturationCode);
  EXPECT_EQ(EncodeSample(std::numeric_limits<float>::infinity()), kSaturationCode);
}

TEST(EncodeSubImage, EveryPixelDecodesToItsCode) {
  const std::vector<float> samples = TestSubFrame(5, 3);
  const std::vector<uint8_t> image = EncodeSubImage(samples);
  ASSERT_EQ(image.size(), 298'496u);
  for (int r = 0; r < kHeight; ++r) {
    for (int x = 0; x < kWidth; ++x) {
      const float value = samples[static_cast<size_t>(r) * kWidth + x];
      ASSERT_EQ(CodeValue(CodeAt(image.data(), x, r)), static_cast<int>(value))
          << "x " << x << " row " << r;
    }
  }
}

TEST(Options, InvalidOptionsAreRefusedNamingTheConstraint) {
  Options options;
  EXPECT_THAT(options.Validate(), IsOk());
  options.speed_mbps = 100;
  EXPECT_THAT(options.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("speed_mbps = 100")));
  options = {};
  options.p0_tables[1].assign(10, 0);
  EXPECT_THAT(options.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("p0_tables[1].size() = 10")));
  options = {};
  options.faults.push_back(Fault::AtPacket(Fault::kShortPacket, 0, 0, 9));
  EXPECT_THAT(options.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("faults[0].packet = 9")));
}

TEST_F(EmulatedKinect2Test, EnumerationFindsTheKinectWithItsSerialAndSuperSpeed) {
  Options options;
  options.serial = "012345678912";
  ASSERT_NO_FATAL_FAILURE(Start(options));
  libusb_device** devices = nullptr;
  const ssize_t count = libusb_get_device_list(context_, &devices);
  ASSERT_EQ(count, 1);
  libusb_device_descriptor descriptor{};
  ASSERT_EQ(libusb_get_device_descriptor(devices[0], &descriptor), 0);
  EXPECT_EQ(descriptor.idVendor, kMicrosoft);
  EXPECT_EQ(descriptor.idProduct, kKinect2);
  EXPECT_EQ(descriptor.bcdUSB, 0x0300);
  EXPECT_EQ(libusb_get_device_speed(devices[0]), LIBUSB_SPEED_SUPER);
  EXPECT_EQ(libusb_get_bus_number(devices[0]), 1);
  EXPECT_EQ(libusb_get_device_address(devices[0]), 2);
  libusb_device_handle* handle = nullptr;
  ASSERT_EQ(libusb_open(devices[0], &handle), 0);
  unsigned char serial[64] = {};
  EXPECT_EQ(
      libusb_get_string_descriptor_ascii(handle, descriptor.iSerialNumber, serial, sizeof(serial)),
      12);
  EXPECT_STREQ(reinterpret_cast<const char*>(serial), "012345678912");
  unsigned char product[64] = {};
  EXPECT_GT(
      libusb_get_string_descriptor_ascii(handle, descriptor.iProduct, product, sizeof(product)), 0);
  EXPECT_STREQ(reinterpret_cast<const char*>(product), "Xbox NUI Sensor");
  libusb_close(handle);
  libusb_free_device_list(devices, 1);
}

TEST_F(EmulatedKinect2Test, ProductIdBusAndSpeedAreConfigurable) {
  Options options;
  options.product_id = 0x02c4;
  options.speed_mbps = 480;
  options.busnum = 3;
  options.devnum = 7;
  ASSERT_NO_FATAL_FAILURE(Start(options));
  EXPECT_EQ(kinect_->DevicePath(), "/dev/bus/usb/003/007");
  libusb_device** devices = nullptr;
  ASSERT_EQ(libusb_get_device_list(context_, &devices), 1);
  libusb_device_descriptor descriptor{};
  ASSERT_EQ(libusb_get_device_descriptor(devices[0], &descriptor), 0);
  EXPECT_EQ(descriptor.idProduct, 0x02c4);
  EXPECT_EQ(libusb_get_device_speed(devices[0]), LIBUSB_SPEED_HIGH);
  EXPECT_EQ(libusb_get_bus_number(devices[0]), 3);
  EXPECT_EQ(libusb_get_device_address(devices[0]), 7);
  libusb_free_device_list(devices, 1);
}

TEST_F(EmulatedKinect2Test, ConfigurationHasTheDepthEndpointWithItsSuperSpeedCompanion) {
  ASSERT_NO_FATAL_FAILURE(Start());
  ASSERT_NO_FATAL_FAILURE(Open());
  libusb_device* device = libusb_get_device(handle_);
  libusb_config_descriptor* config = nullptr;
  ASSERT_EQ(libusb_get_config_descriptor_by_value(device, 1, &config), 0);
  ASSERT_EQ(config->bNumInterfaces, 2);
  const libusb_interface& control = config->interface[0];
  ASSERT_EQ(control.num_altsetting, 1);
  ASSERT_EQ(control.altsetting[0].bNumEndpoints, 3);
  EXPECT_EQ(control.altsetting[0].endpoint[0].bEndpointAddress, 0x02);
  EXPECT_EQ(control.altsetting[0].endpoint[1].bEndpointAddress, 0x81);
  EXPECT_EQ(control.altsetting[0].endpoint[2].bEndpointAddress, 0x83);
  const libusb_interface& depth = config->interface[1];
  ASSERT_EQ(depth.num_altsetting, 2);
  EXPECT_EQ(depth.altsetting[0].bNumEndpoints, 0);
  ASSERT_EQ(depth.altsetting[1].bNumEndpoints, 1);
  const libusb_endpoint_descriptor& iso = depth.altsetting[1].endpoint[0];
  EXPECT_EQ(iso.bEndpointAddress, 0x84);
  EXPECT_EQ(iso.bmAttributes & 3, LIBUSB_TRANSFER_TYPE_ISOCHRONOUS);
  libusb_ss_endpoint_companion_descriptor* companion = nullptr;
  ASSERT_EQ(libusb_get_ss_endpoint_companion_descriptor(context_, &iso, &companion), 0);
  EXPECT_EQ(companion->wBytesPerInterval, 0x8400);
  // What libusb computes for the iso packets (research §1.1: at least 0x8400).
  EXPECT_EQ(libusb_get_max_iso_packet_size(device, 0x84), 0x8400);
  libusb_free_ss_endpoint_companion_descriptor(companion);
  libusb_free_config_descriptor(config);
  int configuration = 0;
  EXPECT_EQ(libusb_get_configuration(handle_, &configuration), 0);
  EXPECT_EQ(configuration, 1);
  EXPECT_TRUE(kinect_->counters().claimed[0]);
  EXPECT_TRUE(kinect_->counters().claimed[1]);
}

TEST_F(EmulatedKinect2Test, StandardRequestsAreAcceptedAndVendorRequestsStall) {
  ASSERT_NO_FATAL_FAILURE(Start());
  ASSERT_NO_FATAL_FAILURE(Open());
  // SET_ISOCH_DELAY (40 ns), SET_FEATURE U1_ENABLE, interface SET_FEATURE FUNCTION_SUSPEND.
  EXPECT_EQ(libusb_control_transfer(handle_, 0x00, 0x31, 40, 0, nullptr, 0, kTimeoutMs), 0);
  EXPECT_EQ(libusb_control_transfer(handle_, 0x00, 0x03, 48, 0, nullptr, 0, kTimeoutMs), 0);
  EXPECT_EQ(libusb_control_transfer(handle_, 0x01, 0x03, 0, 0x0100, nullptr, 0, kTimeoutMs), 0);
  unsigned char data[16] = {};
  EXPECT_EQ(libusb_control_transfer(handle_, 0xC0, 0x01, 0, 0, data, sizeof(data), kTimeoutMs),
            LIBUSB_ERROR_PIPE);
  const std::vector<ReceivedControl> controls = kinect_->ControlRequests();
  ASSERT_GE(controls.size(), 4u);
  EXPECT_EQ(controls[0].request, 0x31);
  EXPECT_EQ(controls[0].value, 40);
  EXPECT_EQ(controls[2].index, 0x0100);
}

TEST_F(EmulatedKinect2Test, FirmwareVersionsComeWithTheirResponseComplete) {
  ASSERT_NO_FATAL_FAILURE(Start());
  ASSERT_NO_FATAL_FAILURE(Open());
  const Reply reply = Command(kReadFirmwareVersions, 0x200, {});
  ASSERT_EQ(reply.sent, 0);
  ASSERT_EQ(reply.data_result, 0);
  ASSERT_EQ(reply.data.size(), 7u * 16u);
  const uint8_t* entry = reply.data.data() + 3 * 16;
  const uint32_t major_minor = U32(entry);
  const std::string version = std::to_string(major_minor >> 16) + "." +
                              std::to_string(major_minor & 0xffff) + "." +
                              std::to_string(U32(entry + 4)) + "." + std::to_string(U32(entry + 8));
  EXPECT_EQ(version, "4.0.3912.0");
  ASSERT_EQ(reply.complete_result, 0);
  ASSERT_EQ(reply.complete.size(), 16u);
  EXPECT_EQ(U32(reply.complete.data()), kCompleteMagic);
  EXPECT_EQ(U32(reply.complete.data() + 4), sequence_);
  const std::vector<ReceivedCommand> commands = kinect_->Commands();
  ASSERT_EQ(commands.size(), 1u);
  EXPECT_EQ(commands[0].command, kReadFirmwareVersions);
  EXPECT_EQ(commands[0].max_response_length, 0x200u);
  EXPECT_EQ(commands[0].sequence, sequence_);
}

TEST_F(EmulatedKinect2Test, DataPagesHaveTheirDocumentedSizesAndContents) {
  Options options;
  options.serial = "501234543042";
  options.intrinsics.fx = 366.5f;
  options.intrinsics.cy = 207.25f;
  options.intrinsics.k3 = 0.125f;
  options.p0_tables[1].assign(static_cast<size_t>(kWidth) * kHeight, 0);
  options.p0_tables[1][0] = 0x1234;
  options.p0_tables[1].back() = 0xBEEF;
  ASSERT_NO_FATAL_FAILURE(Start(options));
  ASSERT_NO_FATAL_FAILURE(Open());

  const Reply serial = Command(kReadData, 0x1C0000, {kPageSerial});
  ASSERT_EQ(serial.data.size(), 0x80u);
  std::string ascii;
  for (size_t i = 0; i < serial.data.size() && serial.data[i] != 0; i += 2) {
    ascii += static_cast<char>(serial.data[i]);
    EXPECT_EQ(serial.data[i + 1], 0);
  }
  EXPECT_EQ(ascii, "501234543042");

  const Reply intrinsics = Command(kReadData, 0x1C0000, {kPageDepthIntrinsics});
  ASSERT_EQ(intrinsics.data.size(), 92u);
  EXPECT_EQ(F32(intrinsics.data.data()), 366.5f);        // fx
  EXPECT_EQ(F32(intrinsics.data.data() + 8), 0.0f);      // unknown0
  EXPECT_EQ(F32(intrinsics.data.data() + 16), 207.25f);  // cy
  EXPECT_EQ(F32(intrinsics.data.data() + 36), 0.125f);   // k3

  const Reply p0 = Command(kReadData, 0x1C0000, {kPageP0Tables});
  ASSERT_EQ(p0.data_result, 0);
  ASSERT_EQ(p0.data.size(), 1'302'672u);
  // Header, then per table: pad, 424 x 512 u16, pad.
  const size_t table1 = 32 + (2 + 2 * 512 * 424 + 2) + 2;
  EXPECT_EQ(p0.data[table1] | p0.data[table1 + 1] << 8, 0x1234);
  const size_t last = table1 + 2 * (512 * 424 - 1);
  EXPECT_EQ(p0.data[last] | p0.data[last + 1] << 8, 0xBEEF);
  EXPECT_EQ(U32(p0.complete.data()), kCompleteMagic);

  EXPECT_EQ(Command(kReadData, 0x1C0000, {kPageRgbParams}).data.size(), 0x1C0u);
  EXPECT_EQ(Command(kReadHardwareInfo, 0x5C, {}).data.size(), 0x5Cu);
  // A response never exceeds what the host asked for.
  EXPECT_EQ(Command(kReadData, 0x40, {kPageSerial}).data.size(), 0x40u);
}

TEST_F(EmulatedKinect2Test, StatusBecomesReadyOnTheSecondPoll) {
  ASSERT_NO_FATAL_FAILURE(Start());
  ASSERT_NO_FATAL_FAILURE(Open());
  std::vector<uint32_t> bit0;
  for (int poll = 0; poll < 3; ++poll) {
    const Reply reply = Command(kReadStatus, 4, {kStatusParam});
    ASSERT_EQ(reply.data.size(), 4u);
    bit0.push_back(U32(reply.data.data()) & 1);
  }
  EXPECT_THAT(bit0, ElementsAre(0u, 1u, 1u));
  EXPECT_EQ(kinect_->counters().status_polls, 3);
}

TEST_F(EmulatedKinect2Test, StatusNeverReadyWhenConfigured) {
  Options options;
  options.status_ready_after_polls = Options::kNever;
  ASSERT_NO_FATAL_FAILURE(Start(options));
  ASSERT_NO_FATAL_FAILURE(Open());
  for (int poll = 0; poll < 5; ++poll) {
    const Reply reply = Command(kReadStatus, 4, {kStatusParam});
    ASSERT_EQ(reply.data.size(), 4u);
    EXPECT_EQ(U32(reply.data.data()) & 1, 0u);
  }
}

TEST_F(EmulatedKinect2Test, CommandsWithoutDataAnswerOnlyComplete) {
  ASSERT_NO_FATAL_FAILURE(Start());
  ASSERT_NO_FATAL_FAILURE(Open());
  for (uint32_t command : {kSetMode, kInitStreams, kStop, 0x77u}) {
    const Reply reply = Command(command, 0, {1});
    ASSERT_EQ(reply.complete_result, 0) << command;
    ASSERT_EQ(reply.complete.size(), 16u);
    EXPECT_EQ(U32(reply.complete.data()), kCompleteMagic);
    EXPECT_EQ(U32(reply.complete.data() + 4), sequence_);
  }
  EXPECT_EQ(kinect_->counters().commands_received, 4);
}

TEST_F(EmulatedKinect2Test, IsoTransfersNeedAlternateSetting1) {
  ASSERT_NO_FATAL_FAILURE(Start());
  ASSERT_NO_FATAL_FAILURE(Open());
  IsoStream stream(context_, handle_, 1, 8, false);
  EXPECT_NE(stream.Submit(), 0);  // the kernel has no endpoint 0x84 at alt 0
  EXPECT_EQ(kinect_->counters().urbs_in_flight, 0);
  ASSERT_EQ(libusb_set_interface_alt_setting(handle_, 1, 1), 0);
  EXPECT_EQ(kinect_->counters().interface1_alt_setting, 1);
  EXPECT_EQ(stream.Submit(), 0);
  stream.CancelAll();
  EXPECT_TRUE(HandleEventsUntil([&stream] { return stream.active == 0; }));
}

TEST_F(EmulatedKinect2Test, IsoPacketsLargerThanTheServiceIntervalAreRefused) {
  ASSERT_NO_FATAL_FAILURE(Start());
  ASSERT_NO_FATAL_FAILURE(Open());
  ASSERT_EQ(libusb_set_interface_alt_setting(handle_, 1, 1), 0);
  std::vector<uint8_t> buffer(2 * (kMaxIsoPacketBytes + 1));
  libusb_transfer* transfer = libusb_alloc_transfer(2);
  libusb_fill_iso_transfer(
      transfer, handle_, 0x84, buffer.data(), static_cast<int>(buffer.size()), 2,
      [](libusb_transfer*) {}, nullptr, 0);
  libusb_set_iso_packet_lengths(transfer, static_cast<unsigned int>(kMaxIsoPacketBytes + 1));
  EXPECT_EQ(libusb_submit_transfer(transfer), LIBUSB_ERROR_INVALID_PARAM);  // EMSGSIZE
  libusb_free_transfer(transfer);
  EXPECT_EQ(kinect_->counters().urbs_in_flight, 0);
}

TEST_F(EmulatedKinect2Test, LeavingAlternateSetting1EndsTheIsoTransfersInFlight) {
  ASSERT_NO_FATAL_FAILURE(Start());
  ASSERT_NO_FATAL_FAILURE(Open());
  ASSERT_EQ(libusb_set_interface_alt_setting(handle_, 1, 1), 0);
  IsoStream stream(context_, handle_, 2, 8, false);  // pending: streaming is off
  ASSERT_EQ(stream.Submit(), 0);
  // The kernel disables the endpoint: its URBs end with -ESHUTDOWN, which libusb reports as
  // NO_DEVICE (libfreenect2 cancels its transfers first).
  ASSERT_EQ(libusb_set_interface_alt_setting(handle_, 1, 0), 0);
  ASSERT_TRUE(HandleEventsUntil([&stream] { return stream.active == 0; }));
  EXPECT_THAT(stream.statuses, ::testing::Each(LIBUSB_TRANSFER_NO_DEVICE));
  EXPECT_EQ(kinect_->counters().interface1_alt_setting, 0);
  EXPECT_FALSE(kinect_->counters().unplugged);
}

TEST_F(EmulatedKinect2Test, StreamCarriesEncodedSubFramesWithTheirFooters) {
  Options options;
  options.renderer = RenderTestSubFrame;
  options.first_timestamp = 1000;
  ASSERT_NO_FATAL_FAILURE(Start(options));
  ASSERT_NO_FATAL_FAILURE(Open());
  ASSERT_NO_FATAL_FAILURE(StartStreaming());
  IsoStream stream(context_, handle_, 8, 8, true);
  const auto start = std::chrono::steady_clock::now();
  ASSERT_NO_FATAL_FAILURE(Stream(stream, 20));
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("iso data through libusb: %.1f MB in %.3f s = %.0f MB/s\n", stream.bytes / 1e6,
              seconds, stream.bytes / 1e6 / seconds);

  const std::vector<SubPacket>& subs = stream.reassembler.subpackets;
  ASSERT_GE(subs.size(), 20u);
  EXPECT_EQ(stream.reassembler.error_packets, 0);
  EXPECT_EQ(stream.reassembler.incomplete, 0);
  EXPECT_EQ(stream.reassembler.overflows, 0);
  for (size_t i = 0; i < subs.size(); ++i) {
    const uint32_t sequence = static_cast<uint32_t>(i / 10);
    const int subframe = static_cast<int>(i % 10);
    EXPECT_EQ(subs[i].sequence, sequence) << i;
    EXPECT_EQ(subs[i].subsequence, static_cast<uint32_t>(subframe)) << i;
    EXPECT_EQ(subs[i].length, 298'496u) << i;
    EXPECT_EQ(subs[i].timestamp, 1000 + 266 * sequence + 26 * static_cast<uint32_t>(subframe));
    for (const auto& [x, r] : {std::pair{0, 0},
                               {1, 0},
                               {511, 0},
                               {5, 211},
                               {6, 212},
                               {300, 300},
                               {511, 423},
                               {7, 100}}) {
      ASSERT_EQ(CodeValue(CodeAt(subs[i].image.data(), x, r)),
                static_cast<int>(TestSample(sequence, subframe, x, r)))
          << "sub-packet " << i << " x " << x << " row " << r;
    }
  }
  const Counters counters = kinect_->counters();
  EXPECT_GE(counters.subframes_served, 20);
  EXPECT_EQ(counters.urbs_in_flight, 0);
  EXPECT_EQ(counters.iso_bytes, stream.bytes);
}

TEST_F(EmulatedKinect2Test, PacketErrorInTheMiddleOfAUrbLeavesLaterPacketsAtTheirOffsets) {
  Options options;
  options.renderer = RenderTestSubFrame;
  options.faults.push_back(Fault::AtPacket(Fault::kPacketError, 0, 0, 3));
  ASSERT_NO_FATAL_FAILURE(Start(options));
  ASSERT_NO_FATAL_FAILURE(Open());
  ASSERT_NO_FATAL_FAILURE(StartStreaming());
  IsoStream stream(context_, handle_, 1, 8, false);
  // The first transfer holds packets 0..7 of sub-frame (0, 0).
  std::vector<std::vector<uint8_t>> packets;
  std::vector<int> packet_statuses;
  stream.observe = [&](libusb_transfer* transfer) {
    if (!packets.empty()) return;
    for (int i = 0; i < transfer->num_iso_packets; ++i) {
      const libusb_iso_packet_descriptor& packet = transfer->iso_packet_desc[i];
      const uint8_t* data = libusb_get_iso_packet_buffer(transfer, static_cast<unsigned int>(i));
      packets.emplace_back(data, data + packet.actual_length);
      packet_statuses.push_back(packet.status);
    }
  };
  ASSERT_NO_FATAL_FAILURE(Stream(stream, 1));
  ASSERT_EQ(stream.statuses[0], LIBUSB_TRANSFER_COMPLETED);
  ASSERT_EQ(packets.size(), 8u);
  const std::vector<uint8_t> image = EncodeSubImage(TestSubFrame(0, 0));
  for (size_t i = 0; i < packets.size(); ++i) {
    if (i == 3) {
      EXPECT_EQ(packet_statuses[i], LIBUSB_TRANSFER_ERROR);
      EXPECT_TRUE(packets[i].empty());
      continue;
    }
    EXPECT_EQ(packet_statuses[i], LIBUSB_TRANSFER_COMPLETED) << i;
    ASSERT_EQ(packets[i].size(), kMaxIsoPacketBytes) << i;
    EXPECT_TRUE(std::equal(packets[i].begin(), packets[i].end(),
                           image.begin() + static_cast<ptrdiff_t>(i * kMaxIsoPacketBytes)))
        << "packet " << i;
  }
  // Sub-frame (0, 0) cannot be assembled; (0, 1) can.
  EXPECT_EQ(stream.reassembler.error_packets, 1);
  ASSERT_FALSE(stream.reassembler.subpackets.empty());
  EXPECT_EQ(stream.reassembler.subpackets[0].subsequence, 1u);
}

TEST_F(EmulatedKinect2Test, StreamFaultsBreakOnlyTheirSubFrames) {
  Options options;
  options.faults = {
      Fault::AtPacket(Fault::kShortPacket, 0, 1, 4),
      Fault::AtPacket(Fault::kZeroLengthPacket, 0, 3, 5),
      Fault::AtSubFrame(Fault::kLostSubPacket, 0, 5),
      Fault::AtSubFrame(Fault::kWrongFooterLength, 0, 7, 1234),
  };
  ASSERT_NO_FATAL_FAILURE(Start(options));
  ASSERT_NO_FATAL_FAILURE(Open());
  ASSERT_NO_FATAL_FAILURE(StartStreaming());
  IsoStream stream(context_, handle_, 4, 8, false);
  ASSERT_NO_FATAL_FAILURE(Stream(stream, 7));
  std::vector<uint32_t> subsequences;
  for (const SubPacket& sub : stream.reassembler.subpackets) {
    if (sub.sequence == 0) subsequences.push_back(sub.subsequence);
    EXPECT_EQ(sub.length, sub.subsequence == 7 && sub.sequence == 0 ? 1234u : 298'496u);
  }
  EXPECT_THAT(subsequences, ElementsAre(0u, 2u, 4u, 6u, 7u, 8u, 9u));
  // Cut short by the next zero-length packet: the short sub-frame; and the one the extra
  // zero-length packet cuts in two, each part.
  EXPECT_EQ(stream.reassembler.incomplete, 3);
  EXPECT_EQ(stream.reassembler.error_packets, 0);
}

TEST_F(EmulatedKinect2Test, CancelledTransfersEndCancelledAndCountAsDiscards) {
  ASSERT_NO_FATAL_FAILURE(Start());
  ASSERT_NO_FATAL_FAILURE(Open());
  // Alt 1 without streaming on: the transfers wait for data.
  ASSERT_EQ(libusb_set_interface_alt_setting(handle_, 1, 1), 0);
  IsoStream stream(context_, handle_, 6, 8, false);
  ASSERT_EQ(stream.Submit(), 0);
  EXPECT_EQ(kinect_->counters().urbs_in_flight, 6);
  EXPECT_EQ(kinect_->counters().iso_urbs_pending, 6);
  stream.CancelAll();
  ASSERT_TRUE(HandleEventsUntil([&stream] { return stream.active == 0; }));
  EXPECT_THAT(stream.statuses, ::testing::Each(LIBUSB_TRANSFER_CANCELLED));
  EXPECT_EQ(stream.statuses.size(), 6u);
  const Counters counters = kinect_->counters();
  EXPECT_EQ(counters.urbs_discarded, 6);
  EXPECT_EQ(counters.urbs_in_flight, 0);
}

TEST_F(EmulatedKinect2Test, CommandTimeoutLeavesTheReadPendingUntilLibusbCancelsIt) {
  Options options;
  options.faults.push_back(Fault::AtCommand(Fault::kCommandTimeout, kReadFirmwareVersions));
  ASSERT_NO_FATAL_FAILURE(Start(options));
  ASSERT_NO_FATAL_FAILURE(Open());
  const Reply timed_out = Command(kReadFirmwareVersions, 0x200, {}, 100);
  EXPECT_EQ(timed_out.sent, 0);
  EXPECT_EQ(timed_out.data_result, LIBUSB_ERROR_TIMEOUT);
  EXPECT_EQ(kinect_->counters().urbs_discarded, 1);
  EXPECT_EQ(kinect_->counters().urbs_in_flight, 0);
  // Only the first occurrence: the next one answers.
  const Reply answered = Command(kReadFirmwareVersions, 0x200, {});
  EXPECT_EQ(answered.data.size(), 112u);
  EXPECT_EQ(answered.complete_result, 0);
}

TEST_F(EmulatedKinect2Test, WrongSequenceComesInTheResponseComplete) {
  Options options;
  options.faults.push_back(Fault::AtCommand(Fault::kWrongSequence, kInitStreams));
  ASSERT_NO_FATAL_FAILURE(Start(options));
  ASSERT_NO_FATAL_FAILURE(Open());
  const Reply reply = Command(kInitStreams, 0, {});
  ASSERT_EQ(reply.complete.size(), 16u);
  EXPECT_EQ(U32(reply.complete.data()), kCompleteMagic);
  EXPECT_EQ(U32(reply.complete.data() + 4), sequence_ + 1);
}

TEST_F(EmulatedKinect2Test, UnplugDuringStreamingEndsTransfersWithNoDevice) {
  Options options;
  options.faults.push_back(Fault::AtSubFrame(Fault::kUnplugStreaming, 1, 0));
  ASSERT_NO_FATAL_FAILURE(Start(options));
  ASSERT_NO_FATAL_FAILURE(Open());
  ASSERT_NO_FATAL_FAILURE(StartStreaming());
  IsoStream stream(context_, handle_, 8, 8, false);
  ASSERT_NO_FATAL_FAILURE(Stream(stream, 1000));
  // Frame 0 came whole; then every transfer in flight ended with NO_DEVICE.
  EXPECT_EQ(stream.reassembler.subpackets.size(), 10u);
  EXPECT_EQ(std::count(stream.statuses.begin(), stream.statuses.end(), LIBUSB_TRANSFER_NO_DEVICE),
            8);
  EXPECT_TRUE(kinect_->counters().unplugged);
  EXPECT_EQ(kinect_->counters().urbs_in_flight, 0);
  // Nothing new reaches the device, and libusb's hotplug thread drops it from the list.
  unsigned char buffer[16] = {};
  int transferred = 0;
  EXPECT_EQ(libusb_bulk_transfer(handle_, 0x02, buffer, 16, &transferred, kTimeoutMs),
            LIBUSB_ERROR_NO_DEVICE);
  EXPECT_TRUE(HandleEventsUntil([this] {
    libusb_device** devices = nullptr;
    const ssize_t count = libusb_get_device_list(context_, &devices);
    libusb_free_device_list(devices, 1);
    return count == 0;
  }));
}

TEST_F(EmulatedKinect2Test, UnplugAtACommandFailsItWithNoDevice) {
  Options options;
  options.faults.push_back(Fault::AtCommand(Fault::kUnplugAtCommand, kInitStreams));
  ASSERT_NO_FATAL_FAILURE(Start(options));
  ASSERT_NO_FATAL_FAILURE(Open());
  EXPECT_EQ(Command(kReadFirmwareVersions, 0x200, {}).complete_result, 0);
  EXPECT_EQ(Command(kInitStreams, 0, {}).sent, LIBUSB_ERROR_NO_DEVICE);
  // Not libusb_set_interface_alt_setting: once libusb's hotplug thread saw the device leave,
  // 1.0.26 unlocks a mutex it never locked there and libusb_close aborts (libusb #1199).
  EXPECT_EQ(libusb_control_transfer(handle_, 0x00, 0x31, 40, 0, nullptr, 0, kTimeoutMs),
            LIBUSB_ERROR_NO_DEVICE);
  EXPECT_TRUE(kinect_->counters().unplugged);
  EXPECT_EQ(kinect_->Commands().size(), 1u);  // the firmware read; 0x09 never arrived
}

TEST_F(EmulatedKinect2Test, UnplugByTheTestEndsPendingTransfers) {
  ASSERT_NO_FATAL_FAILURE(Start());
  ASSERT_NO_FATAL_FAILURE(Open());
  ASSERT_EQ(libusb_set_interface_alt_setting(handle_, 1, 1), 0);
  IsoStream stream(context_, handle_, 3, 8, false);  // pending: streaming is off
  ASSERT_EQ(stream.Submit(), 0);
  kinect_->Unplug();
  ASSERT_TRUE(HandleEventsUntil([&stream] { return stream.active == 0; }));
  EXPECT_THAT(stream.statuses, ::testing::Each(LIBUSB_TRANSFER_NO_DEVICE));
}

TEST_F(EmulatedKinect2Test, RealtimeFramesComeAtTheCameraRateWithIdlePacketsBetween) {
  Options options;
  options.realtime = true;
  options.max_frames = 2;
  ASSERT_NO_FATAL_FAILURE(Start(options));
  ASSERT_NO_FATAL_FAILURE(Open());
  ASSERT_NO_FATAL_FAILURE(StartStreaming());
  IsoStream stream(context_, handle_, 8, 8, false);
  int zero_length = 0;
  stream.observe = [&zero_length](libusb_transfer* transfer) {
    for (int i = 0; i < transfer->num_iso_packets; ++i) {
      if (transfer->status == LIBUSB_TRANSFER_COMPLETED &&
          transfer->iso_packet_desc[i].actual_length == 0) {
        ++zero_length;
      }
    }
  };
  const auto start = std::chrono::steady_clock::now();
  ASSERT_NO_FATAL_FAILURE(Stream(stream, 20));
  const auto elapsed = std::chrono::steady_clock::now() - start;
  ASSERT_EQ(stream.reassembler.subpackets.size(), 20u);
  // The last sub-frame of frame 1 ends 266 + 234 + 9 slots of 125 us after the start.
  EXPECT_GE(elapsed, std::chrono::microseconds(125 * (266 + 234 + 9)));
  // Between sub-frames: 17 idle slots, 23 after the last of a frame.
  EXPECT_GE(zero_length, 2 * (9 * 17) + 23);
  EXPECT_EQ(stream.reassembler.incomplete, 0);
}

TEST_F(EmulatedKinect2Test, FrameLimitEndsTheStream) {
  Options options;
  options.max_frames = 1;
  ASSERT_NO_FATAL_FAILURE(Start(options));
  ASSERT_NO_FATAL_FAILURE(Open());
  ASSERT_NO_FATAL_FAILURE(StartStreaming());
  IsoStream stream(context_, handle_, 4, 8, false);
  ASSERT_EQ(stream.Submit(), 0);
  // 10 sub-frames of 10 packets in 8-packet transfers: 13 transfers, then nothing comes.
  ASSERT_TRUE(HandleEventsUntil([&stream] { return stream.reassembler.subpackets.size() == 10; }));
  ASSERT_TRUE(HandleEventsUntil([this] { return kinect_->counters().iso_urbs_pending == 4; }));
  EXPECT_EQ(kinect_->counters().subframes_served, 10);
  stream.stop = [] { return true; };
  stream.CancelAll();
  ASSERT_TRUE(HandleEventsUntil([&stream] { return stream.active == 0; }));
  EXPECT_EQ(stream.reassembler.subpackets.size(), 10u);
}

}  // namespace
}  // namespace transient::kinect2::testing
