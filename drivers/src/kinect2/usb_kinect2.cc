// A Kinect v2 on libusb-1.0 (usb_kinect2.h).
#include "kinect2/usb_kinect2.h"

#include <libusb.h>

#include <algorithm>
#include <thread>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/time/clock.h"

namespace transient::kinect2 {
namespace {

constexpr uint8_t kCommandOut = 0x02, kCommandIn = 0x81;
constexpr uint8_t kSetIsochDelay = 0x31;  // USB 3 standard request; wValue in ns
constexpr int kIsochDelayNs = 40;
constexpr absl::Duration kStatusPollInterval = absl::Milliseconds(100);
// How long Stop waits for the cancelled transfers' callbacks.
constexpr absl::Duration kCancelTimeout = absl::Seconds(2);

bool IsKinect2(const libusb_device_descriptor& d) {
  if (d.idVendor != kVendorId) return false;
  for (uint16_t p : kProductIds) {
    if (d.idProduct == p) return true;
  }
  return false;
}

int SpeedMbps(int speed) {
  switch (speed) {
    case LIBUSB_SPEED_LOW: return 1;
    case LIBUSB_SPEED_FULL: return 12;
    case LIBUSB_SPEED_HIGH: return 480;
    case LIBUSB_SPEED_SUPER: return 5000;
    default: return speed > LIBUSB_SPEED_SUPER ? 10000 : 0;
  }
}

std::string Where(int bus, int address) {
  return absl::StrFormat("bus %03d device %03d", bus, address);
}

// A libusb error in the words a user needs.
absl::Status UsbError(int code, absl::string_view camera, absl::string_view what,
                      absl::Duration timeout = absl::ZeroDuration()) {
  switch (code) {
    case LIBUSB_ERROR_NO_DEVICE:
      return absl::UnavailableError(absl::StrCat(camera, " was unplugged (", what, ")"));
    case LIBUSB_ERROR_TIMEOUT:
      return absl::UnavailableError(absl::StrCat(camera, ": no answer to ", what, " within ",
                                                 absl::FormatDuration(timeout)));
    case LIBUSB_ERROR_ACCESS:
      return absl::PermissionDeniedError(absl::StrCat(
          camera, ": permission denied (", what, "); install the udev rule ", kUdevRule,
          ", then unplug and replug the camera"));
    case LIBUSB_ERROR_BUSY:
      return absl::FailedPreconditionError(absl::StrCat(
          camera, " is in use by another program (", what, ": busy); close it and retry"));
    default:
      return absl::UnavailableError(
          absl::StrCat(camera, ": ", what, " failed: ", libusb_error_name(code)));
  }
}

// The serial string descriptor of an open device, or "".
std::string SerialOf(libusb_device_handle* handle, const libusb_device_descriptor& d) {
  if (d.iSerialNumber == 0) return "";
  unsigned char text[256];
  const int n = libusb_get_string_descriptor_ascii(handle, d.iSerialNumber, text, sizeof(text));
  return n > 0 ? std::string(reinterpret_cast<char*>(text), static_cast<size_t>(n)) : "";
}

// wBytesPerInterval of the depth endpoint in configuration 1, interface 1, alt 1; 0 if absent.
int DepthBytesPerInterval(libusb_context* context, libusb_device* device) {
  libusb_config_descriptor* config = nullptr;
  if (libusb_get_config_descriptor_by_value(device, 1, &config) != 0) return 0;
  int bytes = 0;
  for (int i = 0; i < config->bNumInterfaces; ++i) {
    const libusb_interface& interface = config->interface[i];
    for (int a = 0; a < interface.num_altsetting; ++a) {
      const libusb_interface_descriptor& alt = interface.altsetting[a];
      if (alt.bInterfaceNumber != kDepthInterface || alt.bAlternateSetting != 1) continue;
      for (int e = 0; e < alt.bNumEndpoints; ++e) {
        if (alt.endpoint[e].bEndpointAddress != kDepthEndpoint) continue;
        libusb_ss_endpoint_companion_descriptor* companion = nullptr;
        if (libusb_get_ss_endpoint_companion_descriptor(context, &alt.endpoint[e], &companion) ==
            0) {
          bytes = companion->wBytesPerInterval;
          libusb_free_ss_endpoint_companion_descriptor(companion);
        }
      }
    }
  }
  libusb_free_config_descriptor(config);
  return bytes;
}

}  // namespace

struct UsbKinect2::Impl {
  UsbKinect2* owner = nullptr;
  UsbKinect2Options options;
  std::string camera;  // "Kinect v2 serial X" for messages
  libusb_context* context = nullptr;
  libusb_device_handle* handle = nullptr;
  bool claimed[2] = {false, false};
  uint32_t sequence = 0;

  bool started = false;
  std::vector<libusb_transfer*> transfers;
  std::vector<std::vector<uint8_t>> buffers;
  std::atomic<int> in_flight{0};
  std::atomic<bool> stopping{false};
  std::atomic<int64_t> stop_deadline_ns{0};
  std::thread events;
  PacketSink sink;

  ~Impl() {
    for (int i = 0; i < 2; ++i) {
      if (claimed[i]) libusb_release_interface(handle, i);
    }
    if (handle != nullptr) libusb_close(handle);
    if (context != nullptr) libusb_exit(context);
  }

  int TimeoutMs() const {
    return static_cast<int>(absl::ToInt64Milliseconds(options.command_timeout));
  }

  absl::Status Error(int code, absl::string_view what) {
    if (code == LIBUSB_ERROR_NO_DEVICE) owner->lost_ = true;
    return UsbError(code, camera, what, options.command_timeout);
  }

  // One command and its response (empty when max_response is 0).
  absl::StatusOr<std::vector<uint8_t>> Command(uint32_t command, std::vector<uint32_t> params,
                                               uint32_t max_response) {
    const uint32_t seq = ++sequence;
    std::vector<uint8_t> bytes = EncodeCommand(seq, command, max_response, params);
    const std::string name = CommandName(command);
    int moved = 0;
    int r = libusb_bulk_transfer(handle, kCommandOut, bytes.data(), static_cast<int>(bytes.size()),
                                 &moved, TimeoutMs());
    if (r != 0) return Error(r, absl::StrCat("sending command ", name));
    if (moved != static_cast<int>(bytes.size())) {
      return absl::DataLossError(absl::StrCat(camera, ": command ", name, " sent ", moved,
                                              " of ", bytes.size(), " bytes"));
    }
    std::vector<uint8_t> response;
    if (max_response > 0) {
      response.resize(max_response);
      r = libusb_bulk_transfer(handle, kCommandIn, response.data(), static_cast<int>(max_response),
                               &moved, TimeoutMs());
      if (r != 0) return Error(r, absl::StrCat("the response to command ", name));
      response.resize(static_cast<size_t>(moved));
    }
    if (max_response > 0 && CheckComplete(response, seq).ok()) {
      return absl::DataLossError(absl::StrCat(camera, ": command ", name,
                                              " was completed without its response data"));
    }
    uint8_t complete[64];
    r = libusb_bulk_transfer(handle, kCommandIn, complete, sizeof(complete), &moved, TimeoutMs());
    if (r != 0) return Error(r, absl::StrCat("the completion of command ", name));
    if (absl::Status status = CheckComplete({complete, static_cast<size_t>(moved)}, seq);
        !status.ok()) {
      return absl::DataLossError(
          absl::StrCat(camera, ": command ", name, ": ", status.message()));
    }
    return response;
  }

  static void LIBUSB_CALL OnTransfer(libusb_transfer* transfer) {
    auto* impl = static_cast<Impl*>(transfer->user_data);
    UsbKinect2* owner = impl->owner;
    switch (transfer->status) {
      case LIBUSB_TRANSFER_CANCELLED:
        --impl->in_flight;
        return;
      case LIBUSB_TRANSFER_NO_DEVICE:
        owner->lost_ = true;
        --impl->in_flight;
        return;
      case LIBUSB_TRANSFER_COMPLETED:
        break;
      default:  // error, stall, overflow, timeout: the packets say what they hold
        ++owner->transfer_errors_;
        break;
    }
    const absl::Time now = absl::Now();
    for (int i = 0; i < transfer->num_iso_packets; ++i) {
      const libusb_iso_packet_descriptor& packet = transfer->iso_packet_desc[i];
      // Each packet's own bytes, at its own offset (never after a skipped packet's).
      const uint8_t* data = libusb_get_iso_packet_buffer_simple(transfer, static_cast<unsigned>(i));
      impl->sink(IsoPacket{{data, packet.actual_length}, static_cast<int>(packet.status)}, now);
    }
    if (impl->stopping.load()) {
      --impl->in_flight;
      return;
    }
    const int r = libusb_submit_transfer(transfer);
    if (r != 0) {
      --impl->in_flight;
      if (r == LIBUSB_ERROR_NO_DEVICE) {
        owner->lost_ = true;
      } else {
        ++owner->transfer_errors_;
      }
    }
  }

  void EventLoop() {
    while (true) {
      const int in = in_flight.load();
      if (in == 0 && (stopping.load() || owner->lost_.load())) return;
      if (stopping.load()) {
        if (absl::GetCurrentTimeNanos() > stop_deadline_ns.load()) return;
        // A callback that checked `stopping` just before Stop set it has resubmitted its
        // transfer after Stop's cancel: cancel again (NOT_FOUND for the others, harmless).
        for (libusb_transfer* transfer : transfers) libusb_cancel_transfer(transfer);
      }
      timeval tv{0, 50'000};
      libusb_handle_events_timeout_completed(context, &tv, nullptr);
    }
  }
};

UsbKinect2::UsbKinect2(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {
  impl_->owner = this;
}

UsbKinect2::~UsbKinect2() { (void)Stop(); }

absl::StatusOr<std::unique_ptr<UsbKinect2>> UsbKinect2::Open(const UsbKinect2Options& options) {
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  if (int r = libusb_init(&impl->context); r != 0) {
    impl->context = nullptr;
    return absl::UnavailableError(
        absl::StrCat("libusb: cannot initialise USB access: ", libusb_error_name(r)));
  }
  libusb_device** list = nullptr;
  const ssize_t count = libusb_get_device_list(impl->context, &list);
  if (count < 0) {
    return absl::UnavailableError(absl::StrCat(
        "libusb: cannot list the USB devices (", libusb_error_name(static_cast<int>(count)),
        "); in a container, pass /dev/bus/usb through"));
  }
  struct Candidate {
    libusb_device* device;
    libusb_device_descriptor descriptor;
    std::string serial;
    int open_error = 0;
  };
  std::vector<Candidate> candidates;
  for (ssize_t i = 0; i < std::max<ssize_t>(count, 0); ++i) {
    libusb_device_descriptor d;
    if (libusb_get_device_descriptor(list[i], &d) != 0 || !IsKinect2(d)) continue;
    Candidate c{list[i], d, "", 0};
    libusb_device_handle* handle = nullptr;
    c.open_error = libusb_open(list[i], &handle);
    if (c.open_error == 0) {
      c.serial = SerialOf(handle, d);
      libusb_close(handle);
    }
    candidates.push_back(c);
  }
  auto where = [](const Candidate& c) {
    return Where(libusb_get_bus_number(c.device), libusb_get_device_address(c.device));
  };
  std::vector<std::string> found;
  for (const Candidate& c : candidates) {
    found.push_back(c.open_error == 0 ? absl::StrCat("serial ", c.serial, " at ", where(c))
                                      : absl::StrCat(where(c), " (cannot open: ",
                                                     libusb_error_name(c.open_error), ")"));
  }
  const Candidate* chosen = nullptr;
  for (const Candidate& c : candidates) {
    if (options.serial.empty() || (c.open_error == 0 && c.serial == options.serial)) {
      if (chosen != nullptr && options.serial.empty()) {
        libusb_free_device_list(list, 1);
        return absl::InvalidArgumentError(absl::StrCat(
            "several Kinect v2 are attached (", absl::StrJoin(found, "; "),
            "); choose one with usb:kinect2?serial=..."));
      }
      if (chosen == nullptr) chosen = &c;
    }
  }
  if (chosen == nullptr) {
    libusb_free_device_list(list, 1);
    if (candidates.empty()) {
      return absl::NotFoundError(
          "no Kinect v2 (045e:02d8 or 045e:02c4) on USB; is its power adapter on and its cable "
          "in a USB 3 port? (lsusb lists it as \"Microsoft Corp. Xbox NUI Sensor\")");
    }
    return absl::NotFoundError(absl::StrCat("no Kinect v2 with serial ", options.serial,
                                            "; found: ", absl::StrJoin(found, "; ")));
  }
  libusb_device* device = chosen->device;
  UsbKinect2Info info;
  info.serial = chosen->serial;
  info.product_id = chosen->descriptor.idProduct;
  info.bus = libusb_get_bus_number(device);
  info.address = libusb_get_device_address(device);
  info.speed_mbps = SpeedMbps(libusb_get_device_speed(device));
  impl->camera = info.serial.empty() ? absl::StrCat("Kinect v2 at ", Where(info.bus, info.address))
                                     : absl::StrCat("Kinect v2 serial ", info.serial);
  if (chosen->open_error != 0) {
    const int code = chosen->open_error;
    libusb_free_device_list(list, 1);
    return UsbError(code, impl->camera, "opening it");
  }
  if (info.speed_mbps < 5000) {
    libusb_free_device_list(list, 1);
    return absl::FailedPreconditionError(absl::StrCat(
        impl->camera, " is on a USB 2 port (", info.speed_mbps,
        " Mbit/s); it needs USB 3 (5000 Mbit/s): plug it into a USB 3 port, one camera per USB 3 "
        "controller"));
  }
  const int bytes_per_interval = DepthBytesPerInterval(impl->context, device);
  if (bytes_per_interval < static_cast<int>(kIsoPacketBytes)) {
    libusb_free_device_list(list, 1);
    return absl::FailedPreconditionError(absl::StrFormat(
        "%s: its depth endpoint 0x84 reserves %d bytes per interval, fewer than the 33792 the "
        "stream needs",
        impl->camera, bytes_per_interval));
  }
  const int r = libusb_open(device, &impl->handle);
  libusb_free_device_list(list, 1);
  if (r != 0) {
    impl->handle = nullptr;
    return UsbError(r, impl->camera, "opening it");
  }
  auto owner = std::unique_ptr<UsbKinect2>(new UsbKinect2(std::move(impl)));
  Impl& d = *owner->impl_;
  int configuration = 0;
  if (int e = libusb_get_configuration(d.handle, &configuration); e != 0) {
    return d.Error(e, "reading its configuration");
  }
  if (configuration != 1) {
    if (int e = libusb_set_configuration(d.handle, 1); e != 0) {
      return d.Error(e, "setting configuration 1");
    }
  }
  for (int i : {kControlInterface, kDepthInterface}) {
    if (int e = libusb_claim_interface(d.handle, i); e != 0) {
      return d.Error(e, absl::StrCat("claiming interface ", i));
    }
    d.claimed[i] = true;
  }
  if (int e = libusb_control_transfer(d.handle, LIBUSB_RECIPIENT_DEVICE, kSetIsochDelay,
                                      kIsochDelayNs, 0, nullptr, 0, d.TimeoutMs());
      e < 0) {
    return d.Error(e, "SET_ISOCH_DELAY");
  }
  if (int e = libusb_set_interface_alt_setting(d.handle, kDepthInterface, 0); e != 0) {
    return d.Error(e, "interface 1 alternate setting 0");
  }
  absl::StatusOr<std::vector<uint8_t>> firmware = d.Command(kReadFirmwareVersions, {}, 0x200);
  if (!firmware.ok()) return firmware.status();
  absl::StatusOr<std::string> version = ParseFirmwareVersion(*firmware);
  if (!version.ok()) {
    return absl::DataLossError(absl::StrCat(d.camera, ": ", version.status().message()));
  }
  info.firmware = *version;
  absl::StatusOr<std::vector<uint8_t>> serial = d.Command(kReadData, {kDataSerial}, 0x80);
  if (!serial.ok()) return serial.status();
  if (info.serial.empty()) {
    absl::StatusOr<std::string> text = ParseSerial(*serial);
    if (text.ok()) info.serial = *text;
  }
  absl::StatusOr<std::vector<uint8_t>> intrinsics =
      d.Command(kReadData, {kDataDepthIntrinsics}, kMaxDataResponse);
  if (!intrinsics.ok()) return intrinsics.status();
  absl::StatusOr<DepthIntrinsics> parsed = ParseDepthIntrinsics(*intrinsics);
  if (!parsed.ok()) {
    return absl::DataLossError(absl::StrCat(d.camera, ": ", parsed.status().message()));
  }
  info.intrinsics = *parsed;
  absl::StatusOr<std::vector<uint8_t>> p0 = d.Command(kReadData, {kDataP0Tables}, kMaxDataResponse);
  if (!p0.ok()) return p0.status();
  if (p0->size() < kP0ResponseBytes) {
    return absl::DataLossError(absl::StrCat(d.camera, ": P0 tables response of ", p0->size(),
                                            " bytes; expected at least ", kP0ResponseBytes));
  }
  info.p0_tables = *std::move(p0);
  owner->info_ = std::move(info);
  return owner;
}

absl::Status UsbKinect2::Start(PacketSink sink) {
  Impl& d = *impl_;
  if (d.started) return absl::FailedPreconditionError(absl::StrCat(d.camera, " already streams"));
  if (d.in_flight.load() > 0) {
    return absl::InternalError(absl::StrCat(d.camera, ": ", d.in_flight.load(),
                                            " transfers of the last stream never came back"));
  }
  for (auto params : {std::vector<uint32_t>{1, 0x00640064}, std::vector<uint32_t>{0}}) {
    if (absl::StatusOr<std::vector<uint8_t>> r = d.Command(kSetMode, params, 0); !r.ok()) {
      return r.status();
    }
  }
  const absl::Time deadline = absl::Now() + d.options.ready_timeout;
  uint32_t status_word = 0;
  while (true) {
    absl::StatusOr<std::vector<uint8_t>> r = d.Command(kReadStatus, {kStatusParam}, 4);
    if (!r.ok()) return r.status();
    absl::StatusOr<uint32_t> word = ParseStatus(*r);
    if (!word.ok()) {
      return absl::DataLossError(absl::StrCat(d.camera, ": ", word.status().message()));
    }
    status_word = *word;
    if (status_word & 1) break;
    if (absl::Now() + kStatusPollInterval > deadline) {
      return absl::UnavailableError(absl::StrFormat(
          "%s is not ready to stream after %s (status 0x%08X, bit 0 never set); unplug and "
          "replug it",
          d.camera, absl::FormatDuration(d.options.ready_timeout), status_word));
    }
    absl::SleepFor(kStatusPollInterval);
  }
  if (absl::StatusOr<std::vector<uint8_t>> r = d.Command(kInitStreams, {}, 0); !r.ok()) {
    return r.status();
  }
  if (int e = libusb_set_interface_alt_setting(d.handle, kDepthInterface, 1); e != 0) {
    return d.Error(e, "interface 1 alternate setting 1 (the depth stream's bandwidth)");
  }
  if (absl::StatusOr<std::vector<uint8_t>> r = d.Command(kSetStreaming, {1}, 0); !r.ok()) {
    return r.status();
  }
  d.sink = std::move(sink);
  d.stopping = false;
  const size_t bytes = static_cast<size_t>(d.options.packets) * kIsoPacketBytes;
  for (int i = 0; i < d.options.transfers; ++i) {
    libusb_transfer* transfer = libusb_alloc_transfer(d.options.packets);
    if (transfer == nullptr) {
      d.started = true;  // what was submitted must be cancelled
      (void)Stop();
      return absl::ResourceExhaustedError(
          absl::StrCat(d.camera, ": libusb cannot allocate an iso transfer"));
    }
    d.buffers.emplace_back(bytes);
    libusb_fill_iso_transfer(transfer, d.handle, kDepthEndpoint, d.buffers.back().data(),
                             static_cast<int>(bytes), d.options.packets, &Impl::OnTransfer, &d, 0);
    libusb_set_iso_packet_lengths(transfer, static_cast<unsigned>(kIsoPacketBytes));
    d.transfers.push_back(transfer);
    ++d.in_flight;
    if (int e = libusb_submit_transfer(transfer); e != 0) {
      --d.in_flight;
      d.started = true;  // what was submitted must be cancelled
      (void)Stop();
      return d.Error(e, "submitting the depth stream's transfers");
    }
  }
  d.started = true;
  d.events = std::thread([&d] { d.EventLoop(); });
  return absl::OkStatus();
}

bool UsbKinect2::stalled() const {
  return impl_->started && !impl_->stopping.load() && impl_->in_flight.load() == 0;
}

absl::Status UsbKinect2::Stop() {
  Impl& d = *impl_;
  if (!d.started) return absl::OkStatus();
  d.stop_deadline_ns = absl::GetCurrentTimeNanos() + absl::ToInt64Nanoseconds(kCancelTimeout);
  d.stopping = true;
  for (libusb_transfer* transfer : d.transfers) libusb_cancel_transfer(transfer);
  if (d.events.joinable()) {
    d.events.join();
  } else {
    // Start failed before the event thread: reap the cancellations here.
    while (d.in_flight.load() > 0 && absl::GetCurrentTimeNanos() < d.stop_deadline_ns.load()) {
      timeval tv{0, 50'000};
      libusb_handle_events_timeout_completed(d.context, &tv, nullptr);
    }
  }
  absl::Status status;
  if (d.in_flight.load() == 0) {
    for (libusb_transfer* transfer : d.transfers) libusb_free_transfer(transfer);
    d.buffers.clear();
  } else {
    // Freeing a transfer libusb still holds would be a use after free: keep them.
    status = absl::InternalError(absl::StrCat(d.camera, ": ", d.in_flight.load(),
                                              " transfers did not come back after cancelling"));
  }
  d.transfers.clear();
  d.started = false;
  if (lost_.load()) return status;
  if (int e = libusb_set_interface_alt_setting(d.handle, kDepthInterface, 0); e != 0) {
    status.Update(d.Error(e, "interface 1 alternate setting 0"));
    return status;
  }
  for (auto [command, params] : {std::pair{kStop, std::vector<uint32_t>{}},
                                 std::pair{kSetStreaming, std::vector<uint32_t>{0}}}) {
    if (absl::StatusOr<std::vector<uint8_t>> r = d.Command(command, params, 0); !r.ok()) {
      status.Update(r.status());
      break;
    }
  }
  return status;
}

std::vector<Kinect2Listing> ListKinect2() {
  std::vector<Kinect2Listing> out;
  libusb_context* context = nullptr;
  if (libusb_init(&context) != 0) return out;
  libusb_device** list = nullptr;
  const ssize_t count = libusb_get_device_list(context, &list);
  for (ssize_t i = 0; i < std::max<ssize_t>(count, 0); ++i) {
    libusb_device_descriptor d;
    if (libusb_get_device_descriptor(list[i], &d) != 0 || !IsKinect2(d)) continue;
    Kinect2Listing listing;
    listing.product_id = d.idProduct;
    listing.bus = libusb_get_bus_number(list[i]);
    listing.address = libusb_get_device_address(list[i]);
    listing.speed_mbps = SpeedMbps(libusb_get_device_speed(list[i]));
    libusb_device_handle* handle = nullptr;
    if (const int r = libusb_open(list[i], &handle); r == 0) {
      listing.serial = SerialOf(handle, d);
      libusb_close(handle);
    } else {
      listing.problem = std::string(
          UsbError(r, "it", "opening it").message());
    }
    if (listing.problem.empty() && listing.speed_mbps < 5000) {
      listing.problem = absl::StrCat("on a USB 2 port (", listing.speed_mbps,
                                     " Mbit/s): it needs USB 3");
    }
    out.push_back(listing);
  }
  if (count >= 0) libusb_free_device_list(list, 1);
  libusb_exit(context);
  return out;
}

}  // namespace transient::kinect2
