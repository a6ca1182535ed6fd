// The openni2: source: depth from any OpenNI2 device or .oni recording, through Debian's
// libOpenNI2 (../shared/research/openni2.md, sections 3 and 6.2). OpenNI2 delivers depth, never
// the phase samples of a ToF camera, so the source declares a depth camera's schedule
// (SamplingScheme::kDepth): the daemon serves depth, range, flags and moment depth maps of it
// and refuses the transient products.
#include <OpenNI.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
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
#include "openni2/openni2_source.h"
#include "source_uri.h"
#include "transient/openni2/oni_frames.h"

namespace transient::openni2 {
namespace {

constexpr SourceKey kKeys[] = {
    {"pace", "realtime", "",
     "a recording: realtime (at its timestamps) or fast (manual playback: every frame once, as "
     "fast as the daemon takes them)"},
    {"loop", "0", "", "a recording: 1 = start again at its end; 0 = its end ends the source"},
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
    } else if (key == "fx" || key == "fy" || key == "cx" || key == "cy") {
      double v = 0;
      const bool focal = key[0] == 'f';
      if (!absl::SimpleAtod(value, &v) || !std::isfinite(v) || (focal && v <= 0)) {
        return internal::BadKeyValue(uri, key, value,
                                     focal ? "a number of pixels > 0" : "a number of pixels");
      }
      (key == "fx" ? o.fx : key == "fy" ? o.fy : key == "cx" ? o.cx : o.cy) = v;
    } else {
      std::string names;
      for (const SourceKey& k : kKeys) absl::StrAppend(&names, names.empty() ? "" : ", ", k.name);
      return absl::InvalidArgumentError(
          absl::StrCat("openni2: unknown key '", key, "'; accepted keys: ", names));
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

  ~OpenNi2Source() override {
    depth_.stop();
    depth_.destroy();
    device_.close();
  }

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
    if (recording_) {
      openni::PlaybackControl* playback = device_.getPlaybackControl();
      playback->setRepeatEnabled(options_.loop);
      // Manual playback delivers every frame once, one per waitForAnyStream; "fastest" (0)
      // would drop frames (research section 3).
      playback->setSpeed(options_.fast ? -1.0f : 1.0f);
      frames_in_file_ = playback->getNumberOfFrames(depth_);
      if (frames_in_file_ <= 0) {
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
    const int max_count = depth_.getMaxPixelValue();
    ScheduleOptions options{.sampling = SamplingScheme::kDepth,
                            .exposure_s = camera_.frame_period_s,
                            .takes = 1,
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
    if (depth_.start() != openni::STATUS_OK) {
      return absl::UnavailableError(
          absl::StrCat(uri_, ": cannot start depth: ", openni::OpenNI::getExtendedError()));
    }
    started_ = true;
    return absl::OkStatus();
  }

  absl::Status Stop() override {
    if (started_) depth_.stop();
    started_ = false;
    return absl::OkStatus();
  }

  absl::Status Next(absl::Duration timeout, RawFrame* frame) override {
    if (!started_) return absl::FailedPreconditionError(uri_ + ": not started");
    if (ended_) return absl::OutOfRangeError(absl::StrCat(uri_, ": end of the recording"));
    openni::VideoStream* streams[] = {&depth_};
    int ready = -1;
    const int timeout_ms = static_cast<int>(
        std::clamp<int64_t>(absl::ToInt64Milliseconds(timeout), 1, kMaxWaitMs));
    const openni::Status waited =
        openni::OpenNI::waitForAnyStream(streams, 1, &ready, timeout_ms);
    if (waited == openni::STATUS_TIME_OUT) {
      return absl::DeadlineExceededError(absl::StrCat(uri_, ": no depth frame within ",
                                                      absl::FormatDuration(timeout)));
    }
    openni::VideoFrameRef ref;
    if (waited != openni::STATUS_OK || depth_.readFrame(&ref) != openni::STATUS_OK) {
      return absl::UnavailableError(
          absl::StrCat(uri_, ": reading depth failed: ", openni::OpenNI::getExtendedError()));
    }
    const int width = camera_.geometry.width, height = camera_.geometry.height;
    if (ref.getWidth() != width || ref.getHeight() != height ||
        ref.getStrideInBytes() < width * static_cast<int>(sizeof(uint16_t)) ||
        ref.getDataSize() < ref.getStrideInBytes() * height) {
      ++frames_dropped_;
      return absl::DataLossError(absl::StrFormat(
          "%s: depth frame %d is %dx%d (stride %d, %d bytes); the stream is %dx%d", uri_,
          ref.getFrameIndex(), ref.getWidth(), ref.getHeight(), ref.getStrideInBytes(),
          ref.getDataSize(), width, height));
    }
    frame->config = schedule_->exposures()[0];
    frame->config.cycle = cycle_;
    frame->config.sequence = static_cast<uint64_t>(cycle_);
    frame->config.timestamp_s = static_cast<double>(ref.getTimestamp()) * 1e-6;
    frame->geometry = camera_.geometry;
    frame->pixels.resize(camera_.geometry.pixel_count());
    const auto* bytes = static_cast<const uint8_t*>(ref.getData());
    for (int v = 0; v < height; ++v) {
      const auto* row = reinterpret_cast<const uint16_t*>(bytes + static_cast<size_t>(v) *
                                                                      ref.getStrideInBytes());
      for (int u = 0; u < width; ++u) {
        frame->pixels[static_cast<size_t>(v) * width + u] = DepthMetres(row[u], unit_);
      }
    }
    ++cycle_;
    // A recording without repeat ends after its last frame (its frames are numbered 1..n).
    if (recording_ && !options_.loop && ref.getFrameIndex() >= frames_in_file_) ended_ = true;
    return absl::OkStatus();
  }

  std::vector<SourceCounter> Counters() const override {
    return {{"frames_dropped_bad_size", frames_dropped_,
             "depth frames whose size or stride did not match the stream's mode"}};
  }

 private:
  const std::string uri_;
  const Options options_;
  openni::Device device_;
  openni::VideoStream depth_;
  CameraInfo camera_;
  std::optional<AcquisitionSchedule> schedule_;
  DepthUnit unit_ = DepthUnit::kMillimetre;
  bool recording_ = false;
  int frames_in_file_ = 0;
  bool started_ = false;
  bool ended_ = false;
  int64_t cycle_ = 0;
  int64_t frames_dropped_ = 0;
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
