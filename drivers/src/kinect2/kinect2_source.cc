// The Kinect v2 capture source (kinect2_source.h).
#include "kinect2/kinect2_source.h"

#include <condition_variable>
#include <deque>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "kinect2/kinect2_format.h"
#include "kinect2/stream_parser.h"
#include "kinect2/usb_kinect2.h"
#include "source_uri.h"

namespace transient::kinect2 {
namespace {

constexpr SourceKey kKeys[] = {
    {"serial", "", "",
     "the camera's serial number (transient devices lists it); empty: the only one"},
    {"queue", "4", "frames",
     "depth frames waiting for the pipeline; when full the oldest is dropped and counted"},
    {"transfers", "16", "", "isochronous transfers in flight"},
    {"packets", "32", "", "packets of 33,792 bytes per transfer"},
    {"command_timeout_ms", "1000", "ms", "how long a command may take to be answered"},
    {"ready_timeout_ms", "5000", "ms", "how long the camera may take to be ready to stream"},
};

struct Kinect2Options {
  UsbKinect2Options usb;
  int queue = 4;
};

absl::StatusOr<Kinect2Options> ParseUri(absl::string_view uri) {
  absl::StatusOr<internal::SourceUri> parsed = internal::ParseSourceUri(uri);
  if (!parsed.ok()) return parsed.status();
  if (parsed->scheme != "usb" || parsed->target != "kinect2") {
    return absl::InvalidArgumentError(absl::StrCat(
        "'", uri, "' is not a Kinect v2 URI; expected usb:kinect2[?serial=...] (the one camera "
                  "this scheme knows)"));
  }
  Kinect2Options o;
  for (const auto& entry : parsed->keys) {
    // Named, not bound: Clang 15 cannot capture structured bindings in the lambda below.
    const std::string& key = entry.first;
    const std::string& value = entry.second;
    auto integer = [&](int* out, int low, int high) -> absl::Status {
      int v = 0;
      if (!absl::SimpleAtoi(value, &v) || v < low || v > high) {
        return internal::BadKeyValue(uri, key, value,
                                     absl::StrCat("an integer in ", low, "..", high));
      }
      *out = v;
      return absl::OkStatus();
    };
    absl::Status status;
    if (key == "serial") {
      o.usb.serial = internal::PercentDecoded(value);
    } else if (key == "queue") {
      status = integer(&o.queue, 1, 64);
    } else if (key == "transfers") {
      status = integer(&o.usb.transfers, 1, 128);
    } else if (key == "packets") {
      status = integer(&o.usb.packets, 1, 128);
    } else if (key == "command_timeout_ms" || key == "ready_timeout_ms") {
      int ms = 0;
      status = integer(&ms, 1, 600'000);
      (key == "command_timeout_ms" ? o.usb.command_timeout : o.usb.ready_timeout) =
          absl::Milliseconds(ms);
    } else {
      return internal::UnknownKey("usb", key, kKeys);
    }
    if (!status.ok()) return status;
  }
  return o;
}

class Kinect2Source final : public CaptureSource {
 public:
  Kinect2Source(std::string uri, Kinect2Options options, std::unique_ptr<UsbKinect2> device,
                AcquisitionSchedule schedule, CalibrationTable calibration)
      : uri_(std::move(uri)),
        options_(std::move(options)),
        device_(std::move(device)),
        schedule_(std::move(schedule)),
        calibration_(std::move(calibration)),
        parser_([this](SubFrame&& s) { assembler_.Add(std::move(s)); }),
        assembler_([this](std::vector<SubFrame>&& frame) { Queue(std::move(frame)); }) {
    const UsbKinect2Info& info = device_->info();
    camera_.geometry = {kWidth, kHeight};
    camera_.intrinsics = {.fx = info.intrinsics.fx,
                          .fy = info.intrinsics.fy,
                          .cx = info.intrinsics.cx,
                          .cy = info.intrinsics.cy};
    camera_.distortion = info.intrinsics.distortion;
    camera_.model = absl::StrCat("Microsoft Kinect v2 (serial ", info.serial, ", firmware ",
                                 info.firmware, ")");
    // Nine raw frames per 33.25 ms frame (the tenth sub-frame's slot shared out, like the
    // simulated Kinect v2's): cycle period = raw frames per cycle x frame period.
    camera_.frame_period_s = kFramePeriodS / kCorrelationSubFrames;
  }
  ~Kinect2Source() override { (void)Stop(); }

  const std::string& uri() const override { return uri_; }
  const CameraInfo& camera() const override { return camera_; }
  const AcquisitionSchedule& schedule() const override { return schedule_; }
  SourceCapabilities capabilities() const override {
    SourceCapabilities c;
    c.min_frequency_hz = 16e6;
    c.max_frequency_hz = 120e6;
    c.min_exposure_s = c.max_exposure_s = kNominalExposureS;  // fixed, not reported
    return c;
  }
  const CalibrationTable* embedded_calibration(std::string* origin) const override {
    if (origin != nullptr) {
      *origin = absl::StrCat("the P0 tables of Kinect v2 serial ", device_->info().serial);
    }
    return &calibration_;
  }

  absl::Status Start() override {
    if (started_) return absl::FailedPreconditionError(absl::StrCat(uri_, " already started"));
    {
      std::lock_guard<std::mutex> lock(mu_);
      parser_.Reset();
      assembler_.Reset();
      queue_.clear();
    }
    absl::Status status = device_->Start([this](const IsoPacket& packet, absl::Time now) {
      std::lock_guard<std::mutex> lock(mu_);
      parser_.Feed(packet, now);
    });
    if (!status.ok()) return status;
    started_ = true;
    return absl::OkStatus();
  }

  absl::Status Next(absl::Duration timeout, RawFrame* frame) override {
    if (!started_) return absl::FailedPreconditionError(absl::StrCat(uri_, ": not started"));
    if (next_ >= current_.size()) {
      std::unique_lock<std::mutex> lock(mu_);
      const absl::Time deadline = absl::Now() + timeout;
      while (queue_.empty() && !device_->lost() && !device_->stalled()) {
        const absl::Duration left = deadline - absl::Now();
        if (left <= absl::ZeroDuration()) {
          return absl::DeadlineExceededError(
              absl::StrCat(uri_, ": no depth frame within ", absl::FormatDuration(timeout)));
        }
        ready_.wait_for(lock, absl::ToChronoNanoseconds(std::min(left, absl::Milliseconds(50))));
      }
      if (queue_.empty() && device_->lost()) {
        return absl::UnavailableError(absl::StrCat("Kinect v2 serial ", device_->info().serial,
                                                   " was unplugged (", uri_, ")"));
      }
      if (queue_.empty()) {
        return absl::UnavailableError(absl::StrCat(
            "Kinect v2 serial ", device_->info().serial, " stopped streaming: no transfer could ",
            "be resubmitted (", device_->transfer_errors(), " transfer errors; ", uri_, ")"));
      }
      current_ = std::move(queue_.front());
      queue_.pop_front();
      next_ = 0;
    }
    const SubFrame& sub = current_[next_];
    const int k = static_cast<int>(sub.footer.subsequence);
    // Since the first complete frame the camera sent (frames dropped since then leave gaps).
    // The footer's counters are 32 bits: the timestamp wraps after 6.2 days.
    const int64_t cycle = static_cast<uint32_t>(sub.footer.sequence - first_sequence_);
    const uint32_t ticks = sub.footer.timestamp - first_timestamp_;
    frame->config = SubFrameExposure(k);
    frame->config.cycle = cycle;
    frame->config.sequence = static_cast<uint64_t>(cycle) * kSubFrames + static_cast<uint64_t>(k);
    frame->config.timestamp_s = static_cast<double>(ticks) * kTimestampUnitS;
    frame->geometry = camera_.geometry;
    frame->pixels.resize(static_cast<size_t>(camera_.geometry.pixel_count()));
    frame->saturation_level = kSaturatedValue;
    ++next_;
    return UnpackSubImage(sub.payload, frame->pixels);
  }

  absl::Status Stop() override {
    if (!started_) return absl::OkStatus();
    started_ = false;
    absl::Status status = device_->Stop();
    std::lock_guard<std::mutex> lock(mu_);
    queue_.clear();
    current_.clear();
    next_ = 0;
    return status;
  }

  std::vector<SourceCounter> Counters() const override {
    std::lock_guard<std::mutex> lock(mu_);
    const StreamCounts& s = parser_.counts();
    const AssemblerCounts& a = assembler_.counts();
    return {
        {"iso_packets", s.packets, "isochronous packets received"},
        {"iso_packet_errors", s.packet_errors, "packets whose status said their data was lost"},
        {"transfer_errors", device_->transfer_errors(),
         "transfers that completed with an error or could not be resubmitted"},
        {"subframes", s.subframes, "sub-frames whose bytes and footer were whole"},
        {"subpackets_lost", s.subpackets_lost, "sub-frames cut by a failed packet"},
        {"subpackets_short", s.subpackets_short, "sub-frames that ended before they were whole"},
        {"subpackets_too_long", s.subpackets_too_long, "sub-frames longer than 298,648 bytes"},
        {"bad_footers", s.bad_footers, "sub-frames whose footer had a wrong length or index"},
        {"frames", a.frames, "depth frames with all nine correlation sub-frames"},
        {"frames_incomplete", a.frames_incomplete, "depth frames dropped: a sub-frame missing"},
        {"frames_dropped_queue", dropped_,
         "complete depth frames dropped because the pipeline was behind (oldest first)"},
        {"subframes_ninth", a.subframes_ninth, "sub-frames 9 (undocumented; not used)"},
        {"subframes_stray", a.subframes_stray, "late or duplicated sub-frames"},
    };
  }

 private:
  // On the event thread, under mu_: a complete depth frame into the bounded queue.
  void Queue(std::vector<SubFrame>&& frame) {
    if (!have_first_) {
      have_first_ = true;
      first_sequence_ = frame.front().footer.sequence;
      first_timestamp_ = frame.front().footer.timestamp;
    }
    if (static_cast<int>(queue_.size()) >= options_.queue) {
      queue_.pop_front();
      ++dropped_;
    }
    queue_.push_back(std::move(frame));
    ready_.notify_one();
  }

  const std::string uri_;
  const Kinect2Options options_;
  std::unique_ptr<UsbKinect2> device_;
  const AcquisitionSchedule schedule_;
  const CalibrationTable calibration_;
  CameraInfo camera_;
  bool started_ = false;

  mutable std::mutex mu_;
  std::condition_variable ready_;
  StreamParser parser_;       // event thread, under mu_
  FrameAssembler assembler_;  // event thread, under mu_
  std::deque<std::vector<SubFrame>> queue_;
  int64_t dropped_ = 0;

  // The first complete frame's footer: written once, on the event thread under mu_ before
  // that frame is queued; read by the consumer after it took a frame from the queue under mu_
  // (so the write happens before). Kept across Stop and Start: the camera's footer counters
  // run on (unverified on a camera: one that restarts them would restart the cycles too).
  bool have_first_ = false;
  uint32_t first_sequence_ = 0, first_timestamp_ = 0;

  // Consumer side.
  std::vector<SubFrame> current_;
  size_t next_ = 0;
};

}  // namespace

std::span<const SourceKey> Kinect2Keys() { return kKeys; }

absl::StatusOr<std::unique_ptr<CaptureSource>> OpenKinect2Source(absl::string_view uri) {
  absl::StatusOr<Kinect2Options> options = ParseUri(uri);
  if (!options.ok()) return options.status();
  absl::StatusOr<std::unique_ptr<UsbKinect2>> device = UsbKinect2::Open(options->usb);
  if (!device.ok()) return device.status();
  absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(Schedule());
  if (!schedule.ok()) return schedule.status();
  absl::StatusOr<CalibrationTable> calibration = CalibrationFromP0((*device)->info().p0_tables);
  if (!calibration.ok()) return calibration.status();
  return std::unique_ptr<CaptureSource>(
      new Kinect2Source(std::string(uri), *std::move(options), *std::move(device),
                        *std::move(schedule), *std::move(calibration)));
}

}  // namespace transient::kinect2

namespace transient::internal {

extern const SourceScheme kUsbScheme;
const SourceScheme kUsbScheme = {
    .name = "usb",
    .syntax = "usb:kinect2?serial=...&key=value&...",
    .description = "a Kinect for Xbox One (Kinect v2) over libusb: raw correlations at 16, 80 "
                   "and 120 MHz; range, depth and amplitude (transient devices lists it)",
    .keys = kinect2::Kinect2Keys(),
    .capabilities = {.embedded_calibration = true},
    .open = kinect2::OpenKinect2Source,
};

}  // namespace transient::internal
