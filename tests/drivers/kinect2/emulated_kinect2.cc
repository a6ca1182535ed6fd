// The emulated Kinect v2's kernel side (usbdevfs) and camera side (emulated_kinect2.h), written
// from the protocol and format descriptions of ../shared/research/libusb.md §1.
#include "tests/drivers/kinect2/emulated_kinect2.h"

// <linux/ioctl.h> before <linux/usbdevice_fs.h> (research §5.2).
#include <linux/ioctl.h>
#include <linux/usb/ch9.h>
#include <linux/usbdevice_fs.h>
#include <umockdev.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <map>
#include <utility>

#include "absl/base/thread_annotations.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/synchronization/mutex.h"

namespace transient::kinect2::testing {
namespace {

using Clock = std::chrono::steady_clock;

constexpr uint16_t kVendorId = 0x045e;
constexpr uint8_t kCommandOut = 0x02;
constexpr uint8_t kCommandIn = 0x81;
constexpr uint8_t kRgbIn = 0x83;
constexpr uint8_t kDepthIn = 0x84;
constexpr int kMaxIsoPacketsPerUrb = 128;  // the kernel's limit
// A sub-packet in packets of at most kMaxIsoPacketBytes: 8 full ones and one of 28,312.
constexpr int kDataPacketsPerSubFrame =
    static_cast<int>((kSubPacketBytes + kMaxIsoPacketBytes - 1) / kMaxIsoPacketBytes);
// One iso packet per 125 us service interval (bInterval 1): a frame lasts kFrameTicks slots,
// sub-frame k starts at slot k * kSubFrameTicks.
constexpr std::chrono::microseconds kSlot(125);
constexpr uint32_t kStatusNotReady = 1024;  // values seen on hardware (libfreenect2 #591)
constexpr uint32_t kStatusReady = 9729;
constexpr int kStringManufacturer = 1;
constexpr int kStringProduct = 2;
constexpr int kStringSerial = 3;

void PutU16(std::vector<uint8_t>& bytes, size_t offset, uint16_t value) {
  bytes[offset] = static_cast<uint8_t>(value);
  bytes[offset + 1] = static_cast<uint8_t>(value >> 8);
}
void PutU32(std::vector<uint8_t>& bytes, size_t offset, uint32_t value) {
  for (int i = 0; i < 4; ++i) bytes[offset + i] = static_cast<uint8_t>(value >> (8 * i));
}
void PutFloat(std::vector<uint8_t>& bytes, size_t offset, float value) {
  uint32_t bits;
  std::memcpy(&bits, &value, sizeof(bits));
  PutU32(bytes, offset, bits);
}
uint32_t GetU32(const uint8_t* at) {
  return static_cast<uint32_t>(at[0]) | static_cast<uint32_t>(at[1]) << 8 |
         static_cast<uint32_t>(at[2]) << 16 | static_cast<uint32_t>(at[3]) << 24;
}
uint16_t GetU16(const uint8_t* at) { return static_cast<uint16_t>(at[0] | at[1] << 8); }

// USB 3.0, class 0xEF/2/1 (a composite device with association descriptors, as the Kinect's
// audio interfaces need), bMaxPacketSize0 2^9.
std::vector<uint8_t> DeviceDescriptor(uint16_t product_id) {
  // clang-format off
  std::vector<uint8_t> d = {
      18, 1, 0x00, 0x03,                       // bLength, DEVICE, bcdUSB 3.00
      0xEF, 0x02, 0x01, 9,                     // class, subclass, protocol, bMaxPacketSize0
      0, 0, 0, 0,                              // idVendor, idProduct (below)
      0x00, 0x01,                              // bcdDevice 1.00
      kStringManufacturer, kStringProduct, kStringSerial,
      1,                                       // bNumConfigurations
  };
  // clang-format on
  PutU16(d, 8, kVendorId);
  PutU16(d, 10, product_id);
  return d;
}

// Configuration 1 (research §1.1). Every SuperSpeed endpoint is followed by its companion; the
// depth endpoint's allows bursts of 11 packets of 1024 bytes, 3 bursts per service interval:
// 33 x 1024 = 0x8400 bytes (wBytesPerInterval).
std::vector<uint8_t> ConfigurationDescriptor() {
  // clang-format off
  std::vector<uint8_t> d = {
      9, 2, 0, 0, 2, 1, 0, 0xC0, 0,            // configuration 1, 2 interfaces, self-powered
      9, 4, 0, 0, 3, 0xFF, 0, 0, 0,            // interface 0: commands and RGB
      7, 5, kCommandOut, 0x02, 0x00, 0x04, 0,  // bulk, 1024 bytes
      6, 0x30, 15, 0, 0, 0,                    // its companion: bursts of 16
      7, 5, kCommandIn, 0x02, 0x00, 0x04, 0,
      6, 0x30, 15, 0, 0, 0,
      7, 5, kRgbIn, 0x02, 0x00, 0x04, 0,
      6, 0x30, 15, 0, 0, 0,
      9, 4, 1, 0, 0, 0xFF, 0, 0, 0,            // interface 1, alt 0: no bandwidth
      9, 4, 1, 1, 1, 0xFF, 0, 0, 0,            // interface 1, alt 1: the depth stream
      7, 5, kDepthIn, 0x01, 0x00, 0x04, 1,     // isochronous, 1024 bytes, every 125 us
      6, 0x30, 10, 2, 0x00, 0x84,              // its companion: wBytesPerInterval 0x8400
  };
  // clang-format on
  PutU16(d, 2, static_cast<uint16_t>(d.size()));
  return d;
}

std::vector<uint8_t> StringDescriptor(const std::string& ascii) {
  std::vector<uint8_t> d = {static_cast<uint8_t>(2 + 2 * ascii.size()), 3};
  for (char c : ascii) {
    d.push_back(static_cast<uint8_t>(c));
    d.push_back(0);
  }
  return d;
}

std::string Hex(const std::vector<uint8_t>& bytes) {
  std::string hex;
  for (uint8_t b : bytes) absl::StrAppendFormat(&hex, "%02x", b);
  return hex;
}

// Aborts: a broken invariant of the emulation or of the test that drives it.
[[noreturn]] void Die(const std::string& message) {
  std::fprintf(stderr, "emulated_kinect2: %s\n", message.c_str());
  std::abort();
}

// The code of a magnitude m in [0, 16,352]: the nearest of 0..255 (step 1), then 128 codes for
// each range r = 0..5 that starts at 256 << r with step 2 << r.
// Ties go up (std::lround of a non-negative value).
uint16_t MagnitudeCode(float m) {
  if (m < 256.0f) return static_cast<uint16_t>(std::lround(m));
  int r = 0;
  while (r < 5 && m >= static_cast<float>(512 << r)) ++r;
  long i = std::lround((m - static_cast<float>(256 << r)) / static_cast<float>(2 << r));
  if (i >= 128) {
    if (r < 5) {
      ++r;
      i = 0;
    } else {
      i = 127;
    }
  }
  return static_cast<uint16_t>(256 + 128 * r + i);
}

bool IsStreamFault(Fault::Kind kind) {
  return kind == Fault::kPacketError || kind == Fault::kShortPacket ||
         kind == Fault::kZeroLengthPacket || kind == Fault::kLostSubPacket ||
         kind == Fault::kWrongFooterLength || kind == Fault::kUnplugStreaming;
}
bool IsPacketFault(Fault::Kind kind) {
  return kind == Fault::kPacketError || kind == Fault::kShortPacket ||
         kind == Fault::kZeroLengthPacket;
}

// A packet the camera sends.
struct IsoPacket {
  const uint8_t* data = nullptr;
  uint32_t length = 0;
  int status = 0;
};

// The camera's depth stream as a sequence of iso packets, sub-frame after sub-frame; the next
// sub-frame is rendered and encoded when its first packet is asked for.
class DepthStream {
 public:
  explicit DepthStream(const Options& options) : options_(options) {}

  // Whether the camera has sent its last frame (Options::max_frames).
  bool Ended() const {
    return !planned_ && options_.max_frames > 0 &&
           static_cast<int64_t>(sequence_) >= options_.max_frames;
  }

  // The next packet; false when the device is to go away at this point (kUnplugStreaming).
  // Precondition: !Ended(). The packet's data stays valid until the next call.
  bool Next(IsoPacket& packet) {
    if (!planned_ && !Plan()) return false;
    const Planned& p = plan_[next_++];
    packet = {bytes_.data() + p.offset, p.length, p.status};
    if (next_ == plan_.size()) {
      if (!lost_) ++subframes_served_;
      planned_ = false;
      if (++subframe_ == kSubFramesPerFrame) {
        subframe_ = 0;
        ++sequence_;
      }
    }
    return true;
  }

  // Streaming stopped: a frame begun is abandoned, the next start begins a new one.
  void Stop() {
    if (planned_ || subframe_ != 0) {
      planned_ = false;
      subframe_ = 0;
      ++sequence_;
    }
  }

  int64_t subframes_served() const { return subframes_served_; }

 private:
  struct Planned {
    uint32_t offset = 0;
    uint32_t length = 0;
    int status = 0;
  };

  // The packets of sub-frame (sequence_, subframe_), with its faults; false for an unplug.
  bool Plan() {
    std::vector<const Fault*> faults;
    for (const Fault& fault : options_.faults) {
      if (IsStreamFault(fault.kind) && fault.sequence == sequence_ && fault.subframe == subframe_) {
        faults.push_back(&fault);
      }
    }
    lost_ = false;
    uint32_t footer_length = static_cast<uint32_t>(kSubImageBytes);
    for (const Fault* fault : faults) {
      if (fault->kind == Fault::kUnplugStreaming) return false;
      if (fault->kind == Fault::kLostSubPacket) lost_ = true;
      if (fault->kind == Fault::kWrongFooterLength) footer_length = fault->value;
    }
    plan_.clear();
    next_ = 0;
    if (!lost_) {
      if (options_.renderer) {
        options_.renderer(sequence_, subframe_, samples_);
      } else {
        std::fill(samples_.begin(), samples_.end(), Options::kDefaultSample);
      }
      EncodeSubImage(samples_, bytes_);  // the footer below; the rest of its 152 bytes stays 0
      const uint32_t timestamp = options_.first_timestamp + sequence_ * kFrameTicks +
                                 static_cast<uint32_t>(subframe_) * kSubFrameTicks;
      const uint32_t footer[6] = {
          kFooterMagic0, kFooterMagic1, timestamp, sequence_, static_cast<uint32_t>(subframe_),
          footer_length};
      for (int i = 0; i < 6; ++i) PutU32(bytes_, kSubImageBytes + 4 * i, footer[i]);
      for (int j = 0; j < kDataPacketsPerSubFrame; ++j) {
        const auto offset = static_cast<uint32_t>(j * kMaxIsoPacketBytes);
        const auto length =
            static_cast<uint32_t>(std::min(kMaxIsoPacketBytes, kSubPacketBytes - offset));
        Planned packet{offset, length, 0};
        for (const Fault* fault : faults) {
          if (fault->packet != j) continue;
          if (fault->kind == Fault::kZeroLengthPacket) plan_.push_back({0, 0, 0});
          if (fault->kind == Fault::kShortPacket) packet.length = length / 2;
          if (fault->kind == Fault::kPacketError) packet = {offset, 0, -EPROTO};
        }
        plan_.push_back(packet);
      }
    } else if (options_.realtime) {
      plan_.assign(kDataPacketsPerSubFrame, Planned{});  // its slots pass empty
    }
    // The idle intervals: one zero-length packet, or in realtime the rest of the sub-frame's
    // slots (the last sub-frame's run to the end of the frame).
    int idle = 1;
    if (options_.realtime) {
      idle = subframe_ < kSubFramesPerFrame - 1
                 ? static_cast<int>(kSubFrameTicks) - kDataPacketsPerSubFrame
                 : static_cast<int>(kFrameTicks - (kSubFramesPerFrame - 1) * kSubFrameTicks) -
                       kDataPacketsPerSubFrame;
    }
    plan_.insert(plan_.end(), idle, Planned{});
    planned_ = true;
    return true;
  }

  const Options& options_;
  uint32_t sequence_ = 0;
  int subframe_ = 0;
  bool planned_ = false;
  bool lost_ = false;
  std::vector<Planned> plan_;
  size_t next_ = 0;
  // The sub-frame's samples, and its sub-packet (sub-image and footer; also the valid pointer
  // of empty packets): allocated once.
  std::vector<float> samples_ = std::vector<float>(static_cast<size_t>(kWidth) * kHeight);
  std::vector<uint8_t> bytes_ = std::vector<uint8_t>(kSubPacketBytes, 0);
  int64_t subframes_served_ = 0;
};

}  // namespace

uint16_t EncodeSample(float value) {
  if (std::isnan(value)) return 0;
  constexpr float kLargestMagnitude = 16320.0f + 32.0f;  // the last code's value + half a step
  const float magnitude = std::fabs(value);
  if (!(magnitude <= kLargestMagnitude) || value >= 32767.0f) return kSaturationCode;
  const uint16_t code = MagnitudeCode(magnitude);
  return value < 0.0f && code != 0 ? static_cast<uint16_t>(1024 + code) : code;
}

void EncodeSubImage(std::span<const float> samples, std::span<uint8_t> bytes) {
  if (samples.size() != static_cast<size_t>(kWidth) * kHeight || bytes.size() < kSubImageBytes) {
    Die(absl::StrCat("EncodeSubImage: ", samples.size(), " samples into ", bytes.size(), " bytes"));
  }
  for (int r = 0; r < kHeight; ++r) {
    // Rows are read out from the middle: the lower half comes in reverse.
    const int stored = r < kHeight / 2 ? r : (kHeight + kHeight / 2 - 1) - r;
    uint8_t* out = bytes.data() + static_cast<size_t>(stored) * kSubImageRowBytes;
    const float* in = samples.data() + static_cast<size_t>(r) * kWidth;
    // The row's slots in order, slot s holding column x = 4 * (s % 128) + s / 128, their codes
    // appended to a little-endian bit stream (512 x 11 bits = 704 bytes, no bits left over).
    uint32_t pending = 0;
    int pending_bits = 0;
    for (int slot = 0; slot < kWidth; ++slot) {
      const int x = 4 * (slot % 128) + slot / 128;
      pending |= static_cast<uint32_t>(EncodeSample(in[x])) << pending_bits;
      pending_bits += 11;
      while (pending_bits >= 8) {
        *out++ = static_cast<uint8_t>(pending);
        pending >>= 8;
        pending_bits -= 8;
      }
    }
  }
}

std::vector<uint8_t> EncodeSubImage(std::span<const float> samples) {
  std::vector<uint8_t> bytes(kSubImageBytes);
  EncodeSubImage(samples, bytes);
  return bytes;
}

absl::Status Options::Validate() const {
  const auto violated = [](const std::string& field, const std::string& constraint) {
    return absl::InvalidArgumentError(absl::StrCat(field, ". Violated constraint: ", constraint));
  };
  if (speed_mbps != 12 && speed_mbps != 480 && speed_mbps != 5000 && speed_mbps != 10000 &&
      speed_mbps != 20000) {
    return violated(absl::StrCat("speed_mbps = ", speed_mbps),
                    "one of 12, 480, 5000, 10000, 20000");
  }
  if (busnum < 1 || busnum > 255) {
    return violated(absl::StrCat("busnum = ", busnum), "1 <= busnum <= 255");
  }
  if (devnum < 1 || devnum > 127) {
    return violated(absl::StrCat("devnum = ", devnum), "1 <= devnum <= 127");
  }
  if (serial.empty() || serial.size() > 63) {
    return violated(absl::StrCat("serial.size() = ", serial.size()), "1 <= serial.size() <= 63");
  }
  for (char c : serial) {
    if (c < 0x20 || c > 0x7e) {
      return violated(absl::StrCat("serial = \"", serial, "\""), "printable ASCII");
    }
  }
  for (size_t g = 0; g < p0_tables.size(); ++g) {
    if (!p0_tables[g].empty() && p0_tables[g].size() != static_cast<size_t>(kWidth) * kHeight) {
      return violated(absl::StrCat("p0_tables[", g, "].size() = ", p0_tables[g].size()),
                      "empty or 512 * 424");
    }
  }
  if (status_ready_after_polls < 0) {
    return violated(absl::StrCat("status_ready_after_polls = ", status_ready_after_polls),
                    "status_ready_after_polls >= 0 (0: never)");
  }
  if (max_frames < 0) {
    return violated(absl::StrCat("max_frames = ", max_frames), "max_frames >= 0");
  }
  for (size_t i = 0; i < faults.size(); ++i) {
    const Fault& fault = faults[i];
    if (IsStreamFault(fault.kind) && (fault.subframe < 0 || fault.subframe >= kSubFramesPerFrame)) {
      return violated(absl::StrCat("faults[", i, "].subframe = ", fault.subframe),
                      "0 <= subframe < 10");
    }
    if (IsPacketFault(fault.kind) &&
        (fault.packet < 0 || fault.packet >= kDataPacketsPerSubFrame)) {
      return violated(absl::StrCat("faults[", i, "].packet = ", fault.packet), "0 <= packet < 9");
    }
    if (!IsStreamFault(fault.kind) && fault.occurrence < Fault::kEveryTime) {
      return violated(absl::StrCat("faults[", i, "].occurrence = ", fault.occurrence),
                      "occurrence >= 0 or kEveryTime");
    }
  }
  return absl::OkStatus();
}

class EmulatedKinect2::Device {
 public:
  explicit Device(Options options)
      : options_(std::move(options)),
        dev_path_(absl::StrFormat("/dev/bus/usb/%03d/%03d", options_.busnum, options_.devnum)),
        sys_path_(absl::StrFormat("/sys/devices/pci0000:00/0000:00:14.0/usb%d/%d-1",
                                  options_.busnum, options_.busnum)),
        stream_(options_) {}

  ~Device() {
    if (testbed_ != nullptr && handler_ != nullptr) {
      umockdev_testbed_detach_ioctl(testbed_, dev_path_.c_str(), nullptr);
    }
    {
      absl::MutexLock lock(&mu_);
      for (Urb& urb : pending_) g_object_unref(urb.data);
      for (Urb& urb : completed_) g_object_unref(urb.data);
      pending_.clear();
      completed_.clear();
    }
    if (handler_ != nullptr) g_object_unref(handler_);
    if (testbed_ != nullptr) g_object_unref(testbed_);
  }

  absl::Status Attach() {
    testbed_ = umockdev_testbed_new();
    handler_ = umockdev_ioctl_base_new();
    g_signal_connect(handler_, "handle-ioctl", G_CALLBACK(HandleIoctl), this);
    GError* error = nullptr;
    // The handler first, so that the node answers as soon as it exists.
    if (!umockdev_testbed_attach_ioctl(testbed_, dev_path_.c_str(), handler_, &error)) {
      return Failed("cannot attach the ioctl handler to ", error);
    }
    const std::string busnum = absl::StrFormat("%03d", options_.busnum);
    const std::string devnum = absl::StrFormat("%03d", options_.devnum);
    std::vector<uint8_t> descriptors = DeviceDescriptor(options_.product_id);
    const std::vector<uint8_t> configuration = ConfigurationDescriptor();
    descriptors.insert(descriptors.end(), configuration.begin(), configuration.end());
    // umockdev's device description: sysfs path (P), node (N), uevent properties (E), sysfs
    // attributes (A, with the kernel's trailing newline escaped) and binary ones (H).
    const auto attribute = [](const std::string& name, const std::string& value) {
      return absl::StrCat("A: ", name, "=", value, "\\n");
    };
    const std::vector<std::string> lines = {
        absl::StrCat("P: ", sys_path_.substr(4)),
        absl::StrCat("N: bus/usb/", busnum, "/", devnum),
        "E: SUBSYSTEM=usb",
        "E: DEVTYPE=usb_device",
        "E: DRIVER=usb",
        absl::StrFormat("E: PRODUCT=45e/%x/100", options_.product_id),
        absl::StrCat("E: BUSNUM=", busnum),
        absl::StrCat("E: DEVNUM=", devnum),
        absl::StrCat("E: DEVNAME=", dev_path_),
        attribute("busnum", absl::StrCat(options_.busnum)),
        attribute("devnum", absl::StrCat(options_.devnum)),
        attribute("speed", absl::StrCat(options_.speed_mbps)),
        attribute("bConfigurationValue", "1"),
        attribute("bNumConfigurations", "1"),
        attribute("bNumInterfaces", " 2"),
        attribute("idVendor", "045e"),
        attribute("idProduct", absl::StrFormat("%04x", options_.product_id)),
        attribute("manufacturer", "Microsoft"),
        attribute("product", "Xbox NUI Sensor"),
        attribute("serial", options_.serial),
        absl::StrCat("H: descriptors=", Hex(descriptors)),
    };
    const std::string description = absl::StrCat(absl::StrJoin(lines, "\n"), "\n");
    if (!umockdev_testbed_add_from_string(testbed_, description.c_str(), &error)) {
      return Failed("cannot add the device: ", error);
    }
    return absl::OkStatus();
  }

  const std::string& dev_path() const { return dev_path_; }

  Counters counters() const {
    absl::MutexLock lock(&mu_);
    Counters c = counters_;
    c.urbs_in_flight = static_cast<int>(pending_.size() + completed_.size());
    c.iso_urbs_pending = static_cast<int>(std::count_if(
        pending_.begin(), pending_.end(), [](const Urb& urb) { return urb.endpoint == kDepthIn; }));
    c.subframes_served = stream_.subframes_served();
    c.commands_received = static_cast<int64_t>(commands_.size());
    return c;
  }
  std::vector<ReceivedCommand> Commands() const {
    absl::MutexLock lock(&mu_);
    return commands_;
  }
  std::vector<ReceivedControl> ControlRequests() const {
    absl::MutexLock lock(&mu_);
    return controls_;
  }

  void Unplug() {
    {
      absl::MutexLock lock(&mu_);
      UnplugLocked();
    }
    RemoveFromTestbedIfDue();
  }

 private:
  // A URB the host submitted: umockdev's copy of the struct (with its iso packet descriptors),
  // written back to the host's when it is reaped; its buffer is the host's, written directly.
  struct Urb {
    UMockdevIoctlData* data = nullptr;  // a reference we hold
    uintptr_t client_address = 0;
    uint8_t type = 0;
    uint8_t endpoint = 0;
    Clock::time_point submitted;
    usbdevfs_urb* urb() const { return reinterpret_cast<usbdevfs_urb*>(data->data); }
    uint8_t* buffer() const { return static_cast<uint8_t*>(urb()->buffer); }
  };

  // What an ioctl returns: its result, or -1 with errno `error`.
  struct Answer {
    long result = 0;
    int error = 0;
  };

  static absl::Status Failed(const std::string& what, GError* error) {
    const std::string message = error != nullptr ? error->message : "unknown error";
    if (error != nullptr) g_error_free(error);
    return absl::InternalError(absl::StrCat("umockdev: ", what, message));
  }

  static gboolean HandleIoctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer data) {
    auto* device = static_cast<Device*>(data);
    Answer answer;
    {
      absl::MutexLock lock(&device->mu_);
      answer = device->Dispatch(client);
    }
    device->RemoveFromTestbedIfDue();
    umockdev_ioctl_client_complete(client, answer.error == 0 ? answer.result : -1, answer.error);
    return TRUE;
  }

  // The pointer-sized argument of the ioctl, resolved to `size` bytes of the host's memory at
  // the address it holds; null for a bad address. The caller unrefs it.
  static UMockdevIoctlData* Resolve(UMockdevIoctlClient* client, size_t size) {
    GError* error = nullptr;
    UMockdevIoctlData* data =
        umockdev_ioctl_data_resolve(umockdev_ioctl_client_get_arg(client), 0, size, &error);
    if (error != nullptr) g_error_free(error);
    return data;
  }
  // The pointer-sized argument itself (an address in the host's memory).
  static uintptr_t ArgumentValue(UMockdevIoctlClient* client) {
    uintptr_t value = 0;
    std::memcpy(&value, umockdev_ioctl_client_get_arg(client)->data, sizeof(value));
    return value;
  }
  template <typename T>
  static bool ReadArgument(UMockdevIoctlClient* client, T& value) {
    UMockdevIoctlData* data = Resolve(client, sizeof(T));
    if (data == nullptr) return false;
    std::memcpy(&value, data->data, sizeof(T));
    g_object_unref(data);
    return true;
  }

  Answer Dispatch(UMockdevIoctlClient* client) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    const unsigned long request = umockdev_ioctl_client_get_request(client);
    if (request == USBDEVFS_REAPURB || request == USBDEVFS_REAPURBNDELAY) return Reap(client);
    // After a disconnect only the completed URBs can still be reaped (the kernel's
    // USBDEVFS_CAP_REAP_AFTER_DISCONNECT).
    if (counters_.unplugged) return {0, ENODEV};
    switch (request) {
      case USBDEVFS_GET_CAPABILITIES: {
        UMockdevIoctlData* data = Resolve(client, sizeof(uint32_t));
        if (data == nullptr) return {0, EFAULT};
        const uint32_t caps = USBDEVFS_CAP_ZERO_PACKET | USBDEVFS_CAP_BULK_CONTINUATION |
                              USBDEVFS_CAP_NO_PACKET_SIZE_LIM | USBDEVFS_CAP_BULK_SCATTER_GATHER |
                              USBDEVFS_CAP_REAP_AFTER_DISCONNECT;
        std::memcpy(data->data, &caps, sizeof(caps));
        g_object_unref(data);
        return {};
      }
      case USBDEVFS_SUBMITURB:
        return Submit(client);
      case USBDEVFS_DISCARDURB:
        return Discard(ArgumentValue(client));
      case USBDEVFS_CLAIMINTERFACE: {
        unsigned int interface = 0;
        if (!ReadArgument(client, interface)) return {0, EFAULT};
        if (counters_.configuration != 1 || interface > 1) return {0, ENOENT};
        counters_.claimed[interface] = true;
        return {};
      }
      case USBDEVFS_DISCONNECT_CLAIM: {
        usbdevfs_disconnect_claim claim{};
        if (!ReadArgument(client, claim)) return {0, EFAULT};
        if (counters_.configuration != 1 || claim.interface > 1) return {0, ENOENT};
        counters_.claimed[claim.interface] = true;
        return {};
      }
      case USBDEVFS_RELEASEINTERFACE: {
        unsigned int interface = 0;
        if (!ReadArgument(client, interface)) return {0, EFAULT};
        if (interface > 1 || !counters_.claimed[interface]) return {0, EINVAL};
        counters_.claimed[interface] = false;
        return {};
      }
      case USBDEVFS_SETINTERFACE: {
        usbdevfs_setinterface setting{};
        if (!ReadArgument(client, setting)) return {0, EFAULT};
        return {0, SetInterface(setting.interface, setting.altsetting)};
      }
      case USBDEVFS_SETCONFIGURATION: {
        int value = 0;
        if (!ReadArgument(client, value)) return {0, EFAULT};
        if (value != 1 && value != 0 && value != -1) return {0, EINVAL};
        if (counters_.claimed[0] || counters_.claimed[1]) return {0, EBUSY};
        KillPending([](const Urb&) { return true; });
        counters_.configuration = value == 1 ? 1 : 0;
        counters_.interface1_alt_setting = 0;
        return {};
      }
      case USBDEVFS_GETDRIVER:
        return {0, ENODATA};  // no kernel driver on any interface
      case USBDEVFS_CONNECTINFO: {
        UMockdevIoctlData* data = Resolve(client, sizeof(usbdevfs_connectinfo));
        if (data == nullptr) return {0, EFAULT};
        const usbdevfs_connectinfo info{static_cast<unsigned int>(options_.devnum), 0};
        std::memcpy(data->data, &info, sizeof(info));
        g_object_unref(data);
        return {};
      }
      case USBDEVFS_GET_SPEED:
        return {options_.speed_mbps >= 5000  ? USB_SPEED_SUPER
                : options_.speed_mbps == 480 ? USB_SPEED_HIGH
                                             : USB_SPEED_FULL,
                0};
      case USBDEVFS_RESET:
      case USBDEVFS_CLEAR_HALT:
      case USBDEVFS_RESETEP:
        return {};
      default:
        return {0, ENOTTY};  // what the kernel says to an ioctl it does not know
    }
  }

  // SUBMITURB: the kernel's checks, then the device's answer (now, or when it has one).
  Answer Submit(UMockdevIoctlClient* client) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    const uintptr_t address = ArgumentValue(client);
    if (address == 0) return {0, EFAULT};
    // In-process the host's pointer is valid: the packet count sizes the one resolve of the
    // struct and its packet descriptors (umockdev caches a resolved child at its first size).
    const auto* peek = reinterpret_cast<const usbdevfs_urb*>(address);
    int packets = 0;
    if (peek->type == USBDEVFS_URB_TYPE_ISO) {
      packets = peek->number_of_packets;
      if (packets < 1 || packets > kMaxIsoPacketsPerUrb) return {0, EINVAL};
    }
    Urb urb;
    urb.data = Resolve(client, sizeof(usbdevfs_urb) +
                                   static_cast<size_t>(packets) * sizeof(usbdevfs_iso_packet_desc));
    if (urb.data == nullptr) return {0, EFAULT};
    urb.client_address = address;
    urb.type = urb.urb()->type;
    urb.endpoint = urb.urb()->endpoint;
    urb.submitted = Clock::now();
    const int refused = Check(urb);
    if (refused != 0) {
      g_object_unref(urb.data);
      return {0, refused};
    }
    ++counters_.urbs_submitted;
    usbdevfs_urb* u = urb.urb();
    u->status = 0;
    u->actual_length = 0;
    u->error_count = 0;
    if (urb.type == USBDEVFS_URB_TYPE_CONTROL) {
      Control(urb);
      completed_.push_back(urb);
    } else if (urb.endpoint == kCommandOut) {
      if (!Command(urb)) {
        g_object_unref(urb.data);
        UnplugLocked();
        return {0, ENODEV};
      }
      completed_.push_back(urb);
    } else {
      pending_.push_back(urb);  // reads on 0x81, 0x83 and iso on 0x84 wait for data
    }
    return {};
  }

  // The kernel's checks of a URB: 0 or the errno SUBMITURB fails with.
  int Check(const Urb& urb) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    const usbdevfs_urb* u = urb.urb();
    if (u->buffer_length < 0 || (u->buffer_length > 0 && u->buffer == nullptr)) return EINVAL;
    switch (urb.type) {
      case USBDEVFS_URB_TYPE_CONTROL:
        if ((urb.endpoint & 0x7f) != 0) return ENOENT;
        if (u->buffer_length < 8) return EINVAL;
        if (GetU16(urb.buffer() + 6) + 8 > u->buffer_length) return EINVAL;
        return 0;
      case USBDEVFS_URB_TYPE_BULK:
        if (counters_.configuration != 1) return ENOENT;
        return urb.endpoint == kCommandOut || urb.endpoint == kCommandIn || urb.endpoint == kRgbIn
                   ? 0
                   : ENOENT;
      case USBDEVFS_URB_TYPE_ISO: {
        if (urb.endpoint != kDepthIn || counters_.configuration != 1 ||
            counters_.interface1_alt_setting != 1) {
          return ENOENT;
        }
        int64_t total = 0;
        for (int i = 0; i < u->number_of_packets; ++i) {
          const unsigned int length = u->iso_frame_desc[i].length;
          if (length > kMaxIsoPacketBytes) return EMSGSIZE;
          total += length;
        }
        return total > u->buffer_length ? EINVAL : 0;
      }
      default:
        return ENOENT;  // no interrupt endpoints
    }
  }

  // A control request on endpoint 0 (SETUP packet first in the buffer).
  void Control(const Urb& urb) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    const uint8_t* setup = urb.buffer();
    const ReceivedControl request{setup[0], setup[1], GetU16(setup + 2), GetU16(setup + 4),
                                  GetU16(setup + 6)};
    controls_.push_back(request);
    usbdevfs_urb* u = urb.urb();
    const bool in = (request.request_type & 0x80) != 0;
    const int type = request.request_type & 0x60;
    const int recipient = request.request_type & 0x1f;
    std::vector<uint8_t> reply;
    bool stall = false;
    if (type != 0) {
      stall = true;                                                // no vendor or class requests
    } else if (in && request.request == 0x06 && recipient == 0) {  // GET_DESCRIPTOR
      const int descriptor = request.value >> 8;
      const int index = request.value & 0xff;
      if (descriptor == 1) {
        reply = DeviceDescriptor(options_.product_id);
      } else if (descriptor == 2 && index == 0) {
        reply = ConfigurationDescriptor();
      } else if (descriptor == 3 && index == 0) {
        reply = {4, 3, 0x09, 0x04};  // English (United States)
      } else if (descriptor == 3 && index == kStringManufacturer) {
        reply = StringDescriptor("Microsoft");
      } else if (descriptor == 3 && index == kStringProduct) {
        reply = StringDescriptor("Xbox NUI Sensor");
      } else if (descriptor == 3 && index == kStringSerial) {
        reply = StringDescriptor(options_.serial);
      } else {
        stall = true;
      }
    } else if (in && request.request == 0x00) {  // GET_STATUS
      reply = {0, 0};
    } else if (in && request.request == 0x08 && recipient == 0) {  // GET_CONFIGURATION
      reply = {static_cast<uint8_t>(counters_.configuration)};
    } else if (!in && (request.request == 0x01 || request.request == 0x03)) {
      // CLEAR_FEATURE / SET_FEATURE: U1/U2 enable on the device, function suspend on an
      // interface (research §1.2).
    } else if (!in && (request.request == 0x30 || request.request == 0x31) && recipient == 0) {
      // SET_SEL, SET_ISOCH_DELAY.
    } else if (!in && request.request == 0x0B && recipient == 1) {  // SET_INTERFACE
      stall = SetInterface(request.index, request.value) != 0;
    } else {
      stall = true;
    }
    if (stall) {
      u->status = -EPIPE;
      return;
    }
    if (in) {
      const size_t length = std::min<size_t>(reply.size(), request.length);
      std::memcpy(urb.buffer() + 8, reply.data(), length);
      u->actual_length = static_cast<int>(length);
    } else {
      u->actual_length = request.length;
    }
  }

  int SetInterface(unsigned int interface, unsigned int alt) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    if (counters_.configuration != 1 || interface > 1 || alt > interface) return EINVAL;
    // The kernel disables the interface's endpoints: their URBs end with -ESHUTDOWN.
    KillPending([interface](const Urb& urb) {
      return interface == 1 ? urb.endpoint == kDepthIn : urb.endpoint != kDepthIn;
    });
    if (interface == 1) {
      counters_.interface1_alt_setting = static_cast<int>(alt);
      next_slot_ = Clock::time_point::min();
    }
    return 0;
  }

  // A command on 0x02 (research §1.2): queues its response and "complete" on 0x81. False when
  // the device goes away instead (kUnplugAtCommand).
  bool Command(const Urb& urb) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    usbdevfs_urb* u = urb.urb();
    const uint8_t* bytes = urb.buffer();
    const int length = u->buffer_length;
    if (length < 20 || length % 4 != 0 || GetU32(bytes) != kCommandMagic) {
      u->status = -EPIPE;  // not a command: the device stalls the endpoint
      return true;
    }
    ReceivedCommand command;
    command.sequence = GetU32(bytes + 4);
    command.max_response_length = GetU32(bytes + 8);
    command.command = GetU32(bytes + 12);
    for (int offset = 20; offset < length; offset += 4) {
      command.params.push_back(GetU32(bytes + offset));
    }
    const int occurrence = occurrences_[command.command]++;
    bool timeout = false;
    bool wrong_sequence = false;
    for (const Fault& fault : options_.faults) {
      if (IsStreamFault(fault.kind) || fault.command != command.command ||
          (fault.occurrence != occurrence && fault.occurrence != Fault::kEveryTime)) {
        continue;
      }
      if (fault.kind == Fault::kUnplugAtCommand) return false;
      if (fault.kind == Fault::kCommandTimeout) timeout = true;
      if (fault.kind == Fault::kWrongSequence) wrong_sequence = true;
    }
    u->actual_length = length;
    const uint32_t param = command.params.empty() ? 0 : command.params[0];
    std::vector<uint8_t> data = ResponseData(command.command, param);
    if (command.command == kSetStreaming) {
      const bool on = param != 0;
      if (counters_.streaming && !on) stream_.Stop();
      counters_.streaming = on;
    }
    if (!timeout) {
      if (command.max_response_length > 0 && !data.empty()) {
        data.resize(std::min<size_t>(data.size(), command.max_response_length));
        responses_.push_back({std::move(data), 0});
      }
      std::vector<uint8_t> complete(kCompleteBytes, 0);
      PutU32(complete, 0, kCompleteMagic);
      PutU32(complete, 4, command.sequence + (wrong_sequence ? 1 : 0));
      responses_.push_back({std::move(complete), 0});
    }
    commands_.push_back(std::move(command));
    return true;
  }

  // The response data of a command (research §1.2); empty: only the "complete".
  std::vector<uint8_t> ResponseData(uint32_t command, uint32_t param)
      ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    switch (command) {
      case kReadFirmwareVersions: {
        std::vector<uint8_t> data(kFirmwareResponseBytes, 0);
        for (int i = 0; i < 7; ++i) {
          // The other entries are other processors' versions; any plausible values.
          FirmwareVersion version{1, static_cast<uint16_t>(i), 100u * static_cast<uint32_t>(i), 0};
          if (i == 3) version = options_.firmware;
          PutU32(data, 16 * i, static_cast<uint32_t>(version.major) << 16 | version.minor);
          PutU32(data, 16 * i + 4, version.revision);
          PutU32(data, 16 * i + 8, version.build);
        }
        return data;
      }
      case kReadHardwareInfo:
        return std::vector<uint8_t>(kHardwareInfoBytes, 0);
      case kReadStatus: {
        std::vector<uint8_t> data(4, 0);
        if (param == kStatusParam) {
          ++counters_.status_polls;
          const int ready_after = options_.status_ready_after_polls;
          const bool ready =
              ready_after != Options::kNever && counters_.status_polls >= ready_after;
          PutU32(data, 0, ready ? kStatusReady : kStatusNotReady);
        }
        return data;
      }
      case kReadData:
        return DataPage(param);
      default:
        return {};  // 0x09, 0x0A, 0x2B, 0x4B and unknown commands: "complete" only
    }
  }

  std::vector<uint8_t> DataPage(uint32_t page) const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    switch (page) {
      case kPageSerial: {
        std::vector<uint8_t> data(kSerialPageBytes, 0);  // UTF-16LE, zero-padded
        for (size_t i = 0; i < options_.serial.size(); ++i) {
          data[2 * i] = static_cast<uint8_t>(options_.serial[i]);
        }
        return data;
      }
      case kPageP0Tables: {
        std::vector<uint8_t> data(kP0TablesBytes, 0);
        for (size_t g = 0; g < 3; ++g) {
          const std::vector<uint16_t>& table = options_.p0_tables[g];
          for (size_t i = 0; i < table.size(); ++i) {
            PutU16(data, kP0TableOffset + g * kP0TableStride + 2 * i, table[i]);
          }
        }
        return data;
      }
      case kPageDepthIntrinsics: {
        const DepthIntrinsics& p = options_.intrinsics;
        const float values[10] = {p.fx, p.fy, 0.0f, p.cx, p.cy, p.k1, p.k2, p.p1, p.p2, p.k3};
        std::vector<uint8_t> data(kDepthIntrinsicsBytes, 0);
        for (int i = 0; i < 10; ++i) PutFloat(data, 4 * i, values[i]);
        return data;
      }
      case kPageRgbParams:
        return std::vector<uint8_t>(kRgbParamsBytes, 0);
      default:
        return {};
    }
  }

  Answer Discard(uintptr_t address) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    for (auto it = pending_.begin(); it != pending_.end(); ++it) {
      if (it->client_address != address) continue;
      Urb urb = *it;
      pending_.erase(it);
      Finish(urb, -ENOENT);
      ++counters_.urbs_discarded;
      return {};
    }
    return {0, EINVAL};  // not pending: completed already (libusb then reaps it)
  }

  // Completes a pending URB without data: `status` for the URB and its packets.
  void Finish(Urb& urb, int status) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    usbdevfs_urb* u = urb.urb();
    u->status = status;
    u->actual_length = 0;
    if (urb.type == USBDEVFS_URB_TYPE_ISO) {
      for (int i = 0; i < u->number_of_packets; ++i) {
        u->iso_frame_desc[i].actual_length = 0;
        u->iso_frame_desc[i].status = static_cast<unsigned int>(status);
      }
      u->error_count = u->number_of_packets;
    }
    completed_.push_back(urb);
  }

  template <typename Predicate>
  void KillPending(Predicate which) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    for (auto it = pending_.begin(); it != pending_.end();) {
      if (which(*it)) {
        Urb urb = *it;
        it = pending_.erase(it);
        Finish(urb, -ESHUTDOWN);
      } else {
        ++it;
      }
    }
  }

  // The device goes away: the kernel ends every pending URB with -ESHUTDOWN.
  void UnplugLocked() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    if (counters_.unplugged) return;
    counters_.unplugged = true;
    counters_.streaming = false;
    KillPending([](const Urb&) { return true; });
    removal_due_ = true;
  }

  // The "remove" uevent (libusb's hotplug thread drops the device from its list) and the
  // device's sysfs directory and node; not under mu_: umockdev does file I/O.
  void RemoveFromTestbedIfDue() ABSL_LOCKS_EXCLUDED(mu_) {
    {
      absl::MutexLock lock(&mu_);
      if (!removal_due_ || removed_) return;
      removed_ = true;
    }
    umockdev_testbed_uevent(testbed_, sys_path_.c_str(), "remove");
    umockdev_testbed_remove_device(testbed_, sys_path_.c_str());
  }

  // REAPURB(NDELAY): the oldest completed URB, after letting the device complete what it can.
  Answer Reap(UMockdevIoctlClient* client) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    if (completed_.empty() && !counters_.unplugged) Advance();
    if (completed_.empty()) return {0, counters_.unplugged ? ENODEV : EAGAIN};
    UMockdevIoctlData* slot = Resolve(client, sizeof(void*));
    if (slot == nullptr) return {0, EFAULT};
    Urb urb = completed_.front();
    completed_.pop_front();
    // The host's pointer now points at its URB, which umockdev writes back with our changes.
    umockdev_ioctl_data_set_ptr(slot, 0, urb.data);
    g_object_unref(slot);
    g_object_unref(urb.data);
    return {};
  }

  // Completes the pending URBs that the device can answer now: reads of 0x81 while responses
  // wait, iso URBs of 0x84 while the stream has data (in realtime: once their slots passed).
  // In fast mode one iso URB per call keeps a busy-polled reap cheap and the stream lazy.
  void Advance() ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    for (auto it = pending_.begin(); it != pending_.end() && !responses_.empty();) {
      if (it->endpoint != kCommandIn) {
        ++it;
        continue;
      }
      Respond(*it);
      completed_.push_back(*it);
      it = pending_.erase(it);
    }
    const Clock::time_point now = Clock::now();
    for (auto it = pending_.begin(); it != pending_.end();) {
      if (it->endpoint != kDepthIn) {
        ++it;
        continue;
      }
      if (!options_.realtime && (!counters_.streaming || stream_.Ended())) return;
      if (options_.realtime) {
        const Clock::time_point first = std::max(next_slot_, it->submitted);
        const Clock::time_point due = first + kSlot * it->urb()->number_of_packets;
        if (now < due) return;
        next_slot_ = due;
      }
      Urb urb = *it;
      it = pending_.erase(it);
      if (!FillIso(urb)) {
        completed_.push_back(urb);
        UnplugLocked();
        return;
      }
      completed_.push_back(urb);
      if (!options_.realtime) return;
    }
  }

  // A read on 0x81 takes the next response, up to its buffer's length.
  void Respond(const Urb& urb) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    Response& response = responses_.front();
    usbdevfs_urb* u = urb.urb();
    const size_t length = std::min<size_t>(response.bytes.size() - response.taken,
                                           static_cast<size_t>(u->buffer_length));
    std::memcpy(urb.buffer(), response.bytes.data() + response.taken, length);
    response.taken += length;
    if (response.taken == response.bytes.size()) responses_.pop_front();
    u->status = 0;
    u->actual_length = static_cast<int>(length);
  }

  // Fills an iso URB with the stream's next packets: packet i at the sum of the requested
  // lengths before it, its actual length and status in its descriptor. False when the stream
  // unplugs the device: the packets not filled end with -ESHUTDOWN, and so does the URB.
  bool FillIso(const Urb& urb) ABSL_EXCLUSIVE_LOCKS_REQUIRED(mu_) {
    usbdevfs_urb* u = urb.urb();
    uint8_t* buffer = urb.buffer();
    size_t offset = 0;
    int total = 0;
    int errors = 0;
    bool unplug = false;
    for (int i = 0; i < u->number_of_packets; ++i) {
      usbdevfs_iso_packet_desc& desc = u->iso_frame_desc[i];
      IsoPacket packet;  // empty: an idle slot
      if (!unplug && counters_.streaming && !stream_.Ended()) unplug = !stream_.Next(packet);
      if (unplug) {
        desc.actual_length = 0;
        desc.status = static_cast<unsigned int>(-ESHUTDOWN);
        ++errors;
        continue;
      }
      uint32_t length = packet.length;
      int status = packet.status;
      if (length > desc.length) {  // the device sent more than the host asked for: babble
        length = desc.length;
        status = -EOVERFLOW;
      }
      if (length > 0) std::memcpy(buffer + offset, packet.data, length);
      desc.actual_length = length;
      desc.status = static_cast<unsigned int>(status);
      if (status != 0) ++errors;
      total += static_cast<int>(length);
      offset += desc.length;
    }
    u->status = unplug ? -ESHUTDOWN : 0;
    u->actual_length = total;
    u->error_count = errors;
    ++counters_.iso_urbs_completed;
    counters_.iso_bytes += total;
    return !unplug;
  }

  struct Response {
    std::vector<uint8_t> bytes;
    size_t taken = 0;
  };

  const Options options_;
  const std::string dev_path_;
  const std::string sys_path_;
  UMockdevTestbed* testbed_ = nullptr;
  UMockdevIoctlBase* handler_ = nullptr;

  // The handler runs on umockdev's thread, the test's calls on the test's.
  mutable absl::Mutex mu_;
  Counters counters_ ABSL_GUARDED_BY(mu_);
  std::deque<Urb> pending_ ABSL_GUARDED_BY(mu_);              // in submission order
  std::deque<Urb> completed_ ABSL_GUARDED_BY(mu_);            // in completion order
  std::deque<Response> responses_ ABSL_GUARDED_BY(mu_);       // on 0x81, in order
  std::map<uint32_t, int> occurrences_ ABSL_GUARDED_BY(mu_);  // per command ID
  std::vector<ReceivedCommand> commands_ ABSL_GUARDED_BY(mu_);
  std::vector<ReceivedControl> controls_ ABSL_GUARDED_BY(mu_);
  DepthStream stream_ ABSL_GUARDED_BY(mu_);
  // Realtime: when the bus has served the slots of the iso URBs completed so far.
  Clock::time_point next_slot_ ABSL_GUARDED_BY(mu_) = Clock::time_point::min();
  bool removal_due_ ABSL_GUARDED_BY(mu_) = false;
  bool removed_ ABSL_GUARDED_BY(mu_) = false;
};

EmulatedKinect2::EmulatedKinect2(std::unique_ptr<Device> device) : device_(std::move(device)) {}
EmulatedKinect2::~EmulatedKinect2() = default;

absl::StatusOr<std::unique_ptr<EmulatedKinect2>> EmulatedKinect2::Create(Options options) {
  if (!Available()) {
    return absl::FailedPreconditionError(
        "not under umockdev: run with LD_PRELOAD=libumockdev-preload.so.0 (ctest does)");
  }
  if (absl::Status status = options.Validate(); !status.ok()) return status;
  auto device = std::make_unique<Device>(std::move(options));
  if (absl::Status status = device->Attach(); !status.ok()) return status;
  return std::unique_ptr<EmulatedKinect2>(new EmulatedKinect2(std::move(device)));
}

bool EmulatedKinect2::Available() {
  // umockdev tells by the inode of /sys, which is the testbed's only while one exists, and
  // keeps its first answer: ask with a testbed. Not a second one: a testbed's end unsets
  // $UMOCKDEV_DIR, which the first one's emulation needs.
  if (std::getenv("UMOCKDEV_DIR") != nullptr) return umockdev_in_mock_environment();
  UMockdevTestbed* probe = umockdev_testbed_new();
  const bool available = umockdev_in_mock_environment();
  g_object_unref(probe);
  return available;
}
std::string EmulatedKinect2::DevicePath() const { return device_->dev_path(); }
Counters EmulatedKinect2::counters() const { return device_->counters(); }
std::vector<ReceivedCommand> EmulatedKinect2::Commands() const { return device_->Commands(); }
std::vector<ReceivedControl> EmulatedKinect2::ControlRequests() const {
  return device_->ControlRequests();
}
void EmulatedKinect2::Unplug() { device_->Unplug(); }

}  // namespace transient::kinect2::testing
