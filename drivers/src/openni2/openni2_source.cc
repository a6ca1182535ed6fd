// The openni2: source: depth from any OpenNI2 device or .oni recording, through Debian's
// libOpenNI2 (../shared/research/openni2.md, sections 3 and 6.2). OpenNI2 delivers depth, never
// the phase samples of a ToF camera, so the source declares a depth camera's schedule
// (SamplingScheme::kDepth): the daemon serves depth, range, flags and moment depth maps of it
// and refuses the transient products.
#include "openni2/openni2_source.h"

#include <OpenNI.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "source_uri.h"
#include "transient/openni2/close_device.h"
#include "transient/openni2/oni_frames.h"

namespace transient::openni2 {
namespace {

constexpr SourceKey kKeys[] = {
    {"pace", "realtime", "",
     "a recording: realtime (at its timestamps) or fast (manual playback: every frame once, as "
     "fast as the daemon takes them)"},
    {"loop", "0", "", "a recording: 1 = start again at its end; 0 = its end ends the source"},
    {"ir", "1", "",
     "1: also the IR stream, as AMPLITUDE, when the device or recording has one of the depth's "
     "size (frames paired by timestamp); 0: depth only"},
    {"fx", "", "px", "focal length; default: from the stream's horizontal field of view"},
    {"fy", "", "px", "focal length; default: from the vertical field of view"},
    {"cx", "", "px", "principal point; default: the image's centre, (width - 1) / 2"},
    {"cy", "", "px", "principal point; default: (height - 1) / 2"},
};

// How long one Next waits at most inside OpenNI2 before it looks at its own timeout again.
constexpr int kMaxWaitMs = 2000;

struct Options {
  std::string target;  // a device URI, an .oni path, or empty (the first device)
  bool fast = false;
  bool loop = false;
  bool ir = true;
  double fx = 0, fy = 0, cx = NAN, cy = NAN;  // 0 / NaN = from the stream
};

absl::StatusOr<Options> ParseUri(absl::string_view uri) {
  absl::StatusOr<internal::SourceUri> parsed = internal::ParseSourceUri(uri);
  if (!parsed.ok()) return parsed.status();
  Options o;
  o.target = internal::PercentDecoded(parsed->target);
  if (absl::StartsWith(o.target, "transient://")) {
    return absl::InvalidArgumentError(absl::StrCat(
        uri, ": transientd does not open its own OpenNI2 device (transient://); name a camera "
             "or an .oni file"));
  }
  for (const auto& entry : parsed->keys) {
    const std::string& key = entry.first;
    const std::string& value = entry.second;
    if (key == "pace") {
      if (value != "realtime" && value != "fast") {
        return internal::BadKeyValue(uri, key, value, "realtime or fast");
      }
      o.fast = value == "fast";
    } else if (key == "loop") {
      if (value != "0" && value != "1") return internal::BadKeyValue(uri, key, value, "0 or 1");
      o.loop = value == "1";
    } else if (key == "ir") {
      if (value != "0" && value != "1") return internal::BadKeyValue(uri, key, value, "0 or 1");
      o.ir = value == "1";
    } else if (key == "fx" || key == "fy" || key == "cx" || key == "cy") {
      double v = 0;
      const bool focal = key[0] == 'f';
      if (!absl::SimpleAtod(value, &v) || !std::isfinite(v) || (focal && v <= 0)) {
        return internal::BadKeyValue(uri, key, value,
                                     focal ? "a number of pixels > 0" : "a number of pixels");
      }
      (key == "fx" ? o.fx : key == "fy" ? o.fy : key == "cx" ? o.cx : o.cy) = v;
    } else {
      return internal::UnknownKey("openni2", key, kKeys);
    }
  }
  return o;
}

// OpenNI2 once per process, before anything else of it (it changes the working directory while
// it loads its drivers: research 5.5), with this project's own driver silenced in it.
absl::Status InitializeOpenNi() {
  static std::once_flag once;
  static openni::Status status = openni::STATUS_ERROR;
  static std::string error;
  std::call_once(once, [] {
    setenv("TRANSIENT_OPENNI2_DISABLE", "1", 1);
    status = openni::OpenNI::initialize();
    if (status != openni::STATUS_OK) error = openni::OpenNI::getExtendedError();
  });
  if (status == openni::STATUS_OK) return absl::OkStatus();
  return absl::UnavailableError(absl::StrCat("OpenNI2 did not initialise: ", error));
}

DepthUnit UnitOf(openni::PixelFormat format) {
  return format == openni::PIXEL_FORMAT_DEPTH_100_UM ? DepthUnit::kHundredMicrometre
                                                     : DepthUnit::kMillimetre;
}

class OpenNi2Source final : public CaptureSource {
 public:
  OpenNi2Source(std::string uri, Options options) : uri_(std::move(uri)), options_(options) {}

  ~OpenNi2Source() override { CloseDevice(device_, {&depth_, &ir_}); }

  absl::Status Open() {
    if (absl::Status status = InitializeOpenNi(); !status.ok()) return status;
    const char* target = options_.target.empty() ? openni::ANY_DEVICE : options_.target.c_str();
    if (device_.open(target) != openni::STATUS_OK) {
      return absl::NotFoundError(absl::StrCat(
          uri_, ": OpenNI2 cannot open ", options_.target.empty() ? "any device" : options_.target,
          ": ", openni::OpenNI::getExtendedError(), " (transient devices lists the devices)"));
    }
    if (device_.getSensorInfo(openni::SENSOR_DEPTH) == nullptr ||
        depth_.create(device_, openni::SENSOR_DEPTH) != openni::STATUS_OK) {
      return absl::InvalidArgumentError(absl::StrCat(uri_, ": the device has no depth stream: ",
                                                     openni::OpenNI::getExtendedError()));
    }
    recording_ = device_.isFile();
    openni::PlaybackControl* playback = recording_ ? device_.getPlaybackControl() : nullptr;
    if (recording_) {
      playback->setRepeatEnabled(options_.loop);
      // Manual playback delivers every frame once, one per waitForAnyStream; "fastest" (0)
      // would drop frames (research section 3).
      playback->setSpeed(options_.fast ? -1.0f : 1.0f);
      depth_in_file_ = playback->getNumberOfFrames(depth_);
      if (depth_in_file_ <= 0) {
        return absl::DataLossError(absl::StrCat(uri_, ": the recording holds no depth frame"));
      }
    } else {
      depth_.setMirroringEnabled(false);  // some devices start mirrored; not all can say
    }
    const openni::VideoMode mode = depth_.getVideoMode();
    const openni::PixelFormat format = mode.getPixelFormat();
    if (format != openni::PIXEL_FORMAT_DEPTH_1_MM && format != openni::PIXEL_FORMAT_DEPTH_100_UM) {
      return absl::InvalidArgumentError(absl::StrCat(
          uri_, ": the depth stream's pixel format is ", static_cast<int>(format),
          "; expected DEPTH_1_MM (100) or DEPTH_100_UM (101)"));
    }
    unit_ = UnitOf(format);
    camera_.geometry = {.width = mode.getResolutionX(), .height = mode.getResolutionY()};
    const double hfov = depth_.getHorizontalFieldOfView();
    const double vfov = depth_.getVerticalFieldOfView();
    PinholeIntrinsics& k = camera_.intrinsics;
    k.fx = options_.fx > 0 ? options_.fx : camera_.geometry.width / (2 * std::tan(hfov / 2));
    k.fy = options_.fy > 0 ? options_.fy : camera_.geometry.height / (2 * std::tan(vfov / 2));
    k.cx = std::isnan(options_.cx) ? 0.5 * (camera_.geometry.width - 1) : options_.cx;
    k.cy = std::isnan(options_.cy) ? 0.5 * (camera_.geometry.height - 1) : options_.cy;
    if (absl::Status valid = k.Validate(); !valid.ok()) {
      return absl::InvalidArgumentError(absl::StrCat(
          uri_, ": the depth stream reports no usable field of view (", hfov, ", ", vfov,
          " rad), so there are no intrinsics: give fx and fy (and cx, cy) in the URI; ",
          valid.message()));
    }
    camera_.model = absl::StrCat("OpenNI2 ", device_.getDeviceInfo().getVendor(), " ",
                                 device_.getDeviceInfo().getName());
    const int fps = mode.getFps() > 0 ? mode.getFps() : 30;
    camera_.frame_period_s = 1.0 / fps;
    if (options_.ir) OpenIr(playback);
    const int max_count = depth_.getMaxPixelValue();
    ScheduleOptions options{.sampling = SamplingScheme::kDepth,
                            .exposure_s = camera_.frame_period_s,
                            .takes = 1,
                            .depth_amplitude = has_ir_,
                            .max_depth_m = (max_count > 0 ? max_count : 65535) *
                                           MetresPerCount(unit_)};
    absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(options);
    if (!schedule.ok()) return schedule.status();
    schedule_.emplace(*std::move(schedule));
    return absl::OkStatus();
  }

  const std::string& uri() const override { return uri_; }
  const CameraInfo& camera() const override { return camera_; }
  const AcquisitionSchedule& schedule() const override { return *schedule_; }
  SourceCapabilities capabilities() const override {
    return {.replay = recording_, .waits_for_consumer = recording_ && options_.fast};
  }

  absl::Status Start() override {
    if (started_) return absl::FailedPreconditionError(uri_ + ": already started");
    if (depth_.start() != openni::STATUS_OK || (has_ir_ && ir_.start() != openni::STATUS_OK)) {
      depth_.stop();
      return absl::UnavailableError(
          absl::StrCat(uri_, ": cannot start streaming: ", openni::OpenNI::getExtendedError()));
    }
    started_ = true;
    return absl::OkStatus();
  }

  absl::Status Stop() override {
    if (started_) {
      depth_.stop();
      if (has_ir_) ir_.stop();
    }
    started_ = false;
    return absl::OkStatus();
  }

  // One raw frame: the depth of a cycle, then (with IR) its amplitude. With IR, the depth and IR
  // frames are paired by timestamp (within half a frame period); a frame without a partner is
  // dropped and counted.
  absl::Status Next(absl::Duration timeout, RawFrame* frame) override {
    if (!started_) return absl::FailedPreconditionError(uri_ + ": not started");
    if (amplitude_pending_) {
      *frame = std::move(amplitude_);
      amplitude_pending_ = false;
      return absl::OkStatus();
    }
    if (ended_) return absl::OutOfRangeError(absl::StrCat(uri_, ": end of the recording"));
    const absl::Time deadline = absl::Now() + timeout;
    openni::VideoStream* streams[] = {&depth_, &ir_};
    while (true) {
      const int64_t left_ms = absl::ToInt64Milliseconds(deadline - absl::Now());
      int ready = -1;
      const openni::Status waited = openni::OpenNI::waitForAnyStream(
          streams, has_ir_ ? 2 : 1, &ready,
          static_cast<int>(std::clamp<int64_t>(left_ms, 1, kMaxWaitMs)));
      if (waited == openni::STATUS_TIME_OUT) {
        if (AtEnd()) {
          ended_ = true;  // the last frames had no partner
          return absl::OutOfRangeError(absl::StrCat(uri_, ": end of the recording"));
        }
        if (absl::Now() < deadline) continue;
        return absl::DeadlineExceededError(
            absl::StrCat(uri_, ": no depth frame within ", absl::FormatDuration(timeout)));
      }
      const bool is_depth = ready == 0;
      openni::VideoFrameRef& held = is_depth ? depth_frame_ : ir_frame_;
      if (waited != openni::STATUS_OK ||
          (is_depth ? depth_ : ir_).readFrame(&held) != openni::STATUS_OK) {
        return absl::UnavailableError(
            absl::StrCat(uri_, ": reading failed: ", openni::OpenNI::getExtendedError()));
      }
      (is_depth ? last_depth_index_ : last_ir_index_) = held.getFrameIndex();
      if (!has_ir_) return Deliver(frame);
      if (!depth_frame_.isValid() || !ir_frame_.isValid()) continue;
      const double apart_s =
          std::abs(static_cast<double>(depth_frame_.getTimestamp()) -
                   static_cast<double>(ir_frame_.getTimestamp())) * 1e-6;
      if (apart_s <= 0.5 * camera_.frame_period_s) return Deliver(frame);
      // Not of one capture: the older one will find no partner.
      ++frames_unpaired_;
      (depth_frame_.getTimestamp() < ir_frame_.getTimestamp() ? depth_frame_ : ir_frame_)
          .release();
    }
  }

  std::vector<SourceCounter> Counters() const override {
    std::vector<SourceCounter> counters = {
        {"frames_dropped_bad_size", frames_dropped_,
         "depth or IR frames whose size or stride did not match the stream's mode"}};
    if (has_ir_) {
      counters.push_back({"frames_unpaired", frames_unpaired_,
                          "depth or IR frames dropped without a partner of the same capture"});
    }
    return counters;
  }

 private:
  // The IR stream, when the device or file has one of the depth's size in 8 or 16 bits.
  void OpenIr(openni::PlaybackControl* playback) {
    if (device_.getSensorInfo(openni::SENSOR_IR) == nullptr ||
        ir_.create(device_, openni::SENSOR_IR) != openni::STATUS_OK) {
      return;
    }
    const int width = camera_.geometry.width, height = camera_.geometry.height;
    if (playback == nullptr) {
      const openni::Array<openni::VideoMode>& modes =
          ir_.getSensorInfo().getSupportedVideoModes();
      for (int i = 0; i < modes.getSize(); ++i) {
        if (modes[i].getResolutionX() == width && modes[i].getResolutionY() == height &&
            modes[i].getPixelFormat() == openni::PIXEL_FORMAT_GRAY16) {
          ir_.setVideoMode(modes[i]);
          break;
        }
      }
    }
    const openni::VideoMode mode = ir_.getVideoMode();
    const openni::PixelFormat format = mode.getPixelFormat();
    if (mode.getResolutionX() != width || mode.getResolutionY() != height ||
        (format != openni::PIXEL_FORMAT_GRAY16 && format != openni::PIXEL_FORMAT_GRAY8)) {
      ir_.destroy();
      return;
    }
    if (playback != nullptr) {
      ir_in_file_ = playback->getNumberOfFrames(ir_);
      if (ir_in_file_ <= 0) {
        ir_.destroy();
        return;
      }
    }
    has_ir_ = true;
  }

  // A recording without repeat whose last frames (of both streams) were read.
  bool AtEnd() const {
    return recording_ && !options_.loop && last_depth_index_ >= depth_in_file_ &&
           (!has_ir_ || last_ir_index_ >= ir_in_file_);
  }

  // A frame's pixels as floats: Z in metres for depth, counts for IR. False when its size or
  // stride does not match the stream's.
  bool Pixels(const openni::VideoFrameRef& ref, bool depth, std::vector<float>* pixels) {
    const int width = camera_.geometry.width, height = camera_.geometry.height;
    const int bytes_per_pixel =
        ref.getVideoMode().getPixelFormat() == openni::PIXEL_FORMAT_GRAY8 ? 1 : 2;
    if (ref.getWidth() != width || ref.getHeight() != height ||
        ref.getStrideInBytes() < width * bytes_per_pixel ||
        ref.getDataSize() < ref.getStrideInBytes() * height) {
      return false;
    }
    pixels->resize(camera_.geometry.pixel_count());
    const auto* bytes = static_cast<const uint8_t*>(ref.getData());
    for (int v = 0; v < height; ++v) {
      const uint8_t* row = bytes + static_cast<size_t>(v) * ref.getStrideInBytes();
      float* out = pixels->data() + static_cast<size_t>(v) * width;
      for (int u = 0; u < width; ++u) {
        if (bytes_per_pixel == 1) {
          out[u] = row[u];
          continue;
        }
        uint16_t count;
        std::memcpy(&count, row + 2 * u, sizeof count);
        out[u] = depth ? DepthMetres(count, unit_) : static_cast<float>(count);
      }
    }
    return true;
  }

  // The held depth frame (and IR frame) as the cycle's raw frames.
  absl::Status Deliver(RawFrame* frame) {
    const openni::VideoFrameRef depth = depth_frame_;
    depth_frame_.release();
    openni::VideoFrameRef ir = ir_frame_;
    ir_frame_.release();
    const bool sizes_fit =
        Pixels(depth, /*depth=*/true, &frame->pixels) &&
        (!has_ir_ || Pixels(ir, /*depth=*/false, &amplitude_.pixels));
    if (AtEnd()) ended_ = true;
    if (!sizes_fit) {
      ++frames_dropped_;
      return absl::DataLossError(absl::StrFormat(
          "%s: frame %d is not the stream's %dx%d (%dx%d, stride %d, %d bytes)", uri_,
          depth.getFrameIndex(), camera_.geometry.width, camera_.geometry.height, depth.getWidth(),
          depth.getHeight(), depth.getStrideInBytes(), depth.getDataSize()));
    }
    const int per_cycle = has_ir_ ? 2 : 1;
    frame->config = schedule_->exposures()[0];
    frame->config.cycle = cycle_;
    frame->config.sequence = static_cast<uint64_t>(cycle_ * per_cycle);
    frame->config.timestamp_s = static_cast<double>(depth.getTimestamp()) * 1e-6;
    frame->geometry = camera_.geometry;
    if (has_ir_) {
      amplitude_.config = schedule_->exposures()[1];
      amplitude_.config.cycle = cycle_;
      amplitude_.config.sequence = static_cast<uint64_t>(cycle_ * per_cycle + 1);
      amplitude_.config.timestamp_s = static_cast<double>(ir.getTimestamp()) * 1e-6;
      amplitude_.geometry = camera_.geometry;
      amplitude_pending_ = true;
    }
    ++cycle_;
    return absl::OkStatus();
  }

  const std::string uri_;
  const Options options_;
  openni::Device device_;
  openni::VideoStream depth_, ir_;
  CameraInfo camera_;
  std::optional<AcquisitionSchedule> schedule_;
  DepthUnit unit_ = DepthUnit::kMillimetre;
  bool recording_ = false;
  bool has_ir_ = false;
  int depth_in_file_ = 0, ir_in_file_ = 0;  // frames of each stream in a recording
  int last_depth_index_ = 0, last_ir_index_ = 0;
  openni::VideoFrameRef depth_frame_, ir_frame_;  // read, waiting for a partner
  RawFrame amplitude_;                            // the cycle's second frame, when pending
  bool amplitude_pending_ = false;
  bool started_ = false;
  bool ended_ = false;
  int64_t cycle_ = 0;
  int64_t frames_dropped_ = 0;
  int64_t frames_unpaired_ = 0;
};

}  // namespace

absl::StatusOr<std::unique_ptr<CaptureSource>> OpenOpenNi2Source(absl::string_view uri) {
  absl::StatusOr<Options> options = ParseUri(uri);
  if (!options.ok()) return options.status();
  auto source = std::make_unique<OpenNi2Source>(std::string(uri), *options);
  if (absl::Status status = source->Open(); !status.ok()) return status;
  return source;
}

std::span<const SourceKey> OpenNi2Keys() { return kKeys; }

std::vector<CaptureDevice> ListOpenNi2Devices() {
  std::vector<CaptureDevice> devices;
  if (!InitializeOpenNi().ok()) return devices;
  openni::Array<openni::DeviceInfo> found;
  openni::OpenNI::enumerateDevices(&found);
  for (int i = 0; i < found.getSize(); ++i) {
    const openni::DeviceInfo& info = found[i];
    CaptureDevice device;
    device.uri = absl::StrCat("openni2:", info.getUri());
    device.name = absl::StrCat(info.getVendor(), " ", info.getName());
    device.usable = true;
    device.details.push_back(absl::StrFormat("OpenNI2 device, USB %04x:%04x; depth only (no "
                                             "phase samples: no transient products)",
                                             info.getUsbVendorId(), info.getUsbProductId()));
    devices.push_back(std::move(device));
  }
  return devices;
}

}  // namespace transient::openni2

namespace transient::internal {

extern const SourceScheme kOpenNi2Scheme;
const SourceScheme kOpenNi2Scheme = {
    .name = "openni2",
    .syntax = "openni2:<device URI or file.oni>?key=value&...",
    .description = "any OpenNI2 device or .oni recording (Debian's libOpenNI2): depth only, so "
                   "depth, range, flags and moment depth maps, no transient products "
                   "(transient devices lists the devices)",
    .keys = openni2::OpenNi2Keys(),
    .capabilities = {.pace = true, .delivers_depth = true},
    .open = openni2::OpenOpenNi2Source,
};

}  // namespace transient::internal
