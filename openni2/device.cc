#include "device.h"

#include <PS1080.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <optional>
#include <utility>

#include "absl/strings/str_cat.h"

namespace transient::openni2 {
namespace {

// The rate every mode announces: applications ask for exactly 30 (ROS, PCL, RTAB-Map). The
// frames come at the daemon's rate.
constexpr int kModeFps = 30;
// PS1080's zero plane distance in mm; with the pixel size below it gives OpenCV the focal
// length of the 640 x 480 stream (ZPD / (2 ZPPS) = f at VGA, openni2.md section 2.4).
constexpr uint64_t kZeroPlaneDistanceMm = 120;
// The frame interval a restarted daemon's first frame is placed after the previous one's.
constexpr uint64_t kRestartGapUs = 33333;

bool IsDepth(OniSensorType type) { return type == ONI_SENSOR_DEPTH; }

// Bytes per pixel: 3 for the colour stream's RGB888, 2 for depth and IR.
int BytesPerPixel(OniSensorType type) { return type == ONI_SENSOR_COLOR ? 3 : 2; }

DepthUnit UnitOf(OniPixelFormat format) {
  return format == ONI_PIXEL_FORMAT_DEPTH_100_UM ? DepthUnit::kHundredMicrometre
                                                 : DepthUnit::kMillimetre;
}

// Writes `value` as an integer of the size the caller gave (applications pass 4 or 8 bytes).
OniStatus PutInteger(int64_t value, void* data, int* size) {
  if (*size == static_cast<int>(sizeof(int32_t))) {
    const auto narrow = static_cast<int32_t>(value);
    std::memcpy(data, &narrow, sizeof narrow);
    return ONI_STATUS_OK;
  }
  if (*size == static_cast<int>(sizeof(int64_t))) {
    std::memcpy(data, &value, sizeof value);
    return ONI_STATUS_OK;
  }
  return ONI_STATUS_BAD_PARAMETER;
}

// A float or double property, by the caller's size.
OniStatus PutReal(double value, void* data, int* size) {
  if (*size == static_cast<int>(sizeof(float))) {
    const auto narrow = static_cast<float>(value);
    std::memcpy(data, &narrow, sizeof narrow);
    return ONI_STATUS_OK;
  }
  if (*size == static_cast<int>(sizeof(double))) {
    std::memcpy(data, &value, sizeof value);
    return ONI_STATUS_OK;
  }
  return ONI_STATUS_BAD_PARAMETER;
}

template <typename T>
OniStatus PutExactly(const T& value, void* data, int* size) {
  if (*size != static_cast<int>(sizeof(T))) return ONI_STATUS_BAD_PARAMETER;
  std::memcpy(data, &value, sizeof(T));
  return ONI_STATUS_OK;
}

// A NUL-terminated string into at most *size bytes; *size becomes the bytes written.
OniStatus PutString(const std::string& value, void* data, int* size) {
  if (*size <= 0) return ONI_STATUS_BAD_PARAMETER;
  const size_t n = std::min(value.size(), static_cast<size_t>(*size) - 1);
  std::memcpy(data, value.data(), n);
  static_cast<char*>(data)[n] = '\0';
  *size = static_cast<int>(n + 1);
  return ONI_STATUS_OK;
}

CameraInfo SensorOf(const v1::Info& info) {
  CameraInfo camera;
  camera.geometry = {.width = static_cast<int>(info.camera().width()),
                     .height = static_cast<int>(info.camera().height())};
  camera.intrinsics = {.fx = info.camera().fx(), .fy = info.camera().fy(),
                       .cx = info.camera().cx(), .cy = info.camera().cy()};
  camera.model = info.camera().model();
  return camera;
}

// The sensor's size, OpenNI2's standard sizes, and the URI's size, each once.
std::vector<std::pair<int, int>> ModeSizes(const CameraInfo& sensor, const DeviceUri& uri) {
  std::vector<std::pair<int, int>> sizes;
  for (const std::pair<int, int>& size :
       {std::pair{sensor.geometry.width, sensor.geometry.height}, std::pair{640, 480},
        std::pair{320, 240}, std::pair{uri.width, uri.height}}) {
    if (size.first > 0 && std::find(sizes.begin(), sizes.end(), size) == sizes.end()) {
      sizes.push_back(size);
    }
  }
  return sizes;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Stream

Stream::Stream(Device* device, OniSensorType type, const OniVideoMode& mode)
    : device_(device), type_(type), mode_(mode) {
  UpdateGeometry();
}

void Stream::UpdateGeometry() {
  camera_ = VirtualCameraFor(device_->sensor(), mode_.resolutionX, mode_.resolutionY);
  map_ = ResampleMap(device_->sensor(), camera_);
}

uint16_t Stream::MaxValue() const {
  if (type_ == ONI_SENSOR_COLOR) return 255;
  if (!IsDepth(type_)) return 65535;
  return MaxDepthCount(device_->max_depth_m(), UnitOf(mode_.pixelFormat));
}

OniStatus Stream::start() {
  device_->StartStream(this);
  return ONI_STATUS_OK;
}

void Stream::stop() { device_->StopStream(this); }

OniBool Stream::isPropertySupported(int id) {
  switch (id) {
    case ONI_STREAM_PROPERTY_VIDEO_MODE:
    case ONI_STREAM_PROPERTY_HORIZONTAL_FOV:
    case ONI_STREAM_PROPERTY_VERTICAL_FOV:
    case ONI_STREAM_PROPERTY_MAX_VALUE:
    case ONI_STREAM_PROPERTY_MIN_VALUE:
    case ONI_STREAM_PROPERTY_STRIDE:
    case ONI_STREAM_PROPERTY_MIRRORING:
    case ONI_STREAM_PROPERTY_CROPPING:
      return TRUE;
    case XN_STREAM_PROPERTY_ZERO_PLANE_DISTANCE:
    case XN_STREAM_PROPERTY_ZERO_PLANE_PIXEL_SIZE:
    case XN_STREAM_PROPERTY_EMITTER_DCMOS_DISTANCE:
      return IsDepth(type_) ? TRUE : FALSE;
    default:
      return FALSE;
  }
}

OniStatus Stream::getProperty(int id, void* data, int* size) {
  if (data == nullptr || size == nullptr) return ONI_STATUS_BAD_PARAMETER;
  std::lock_guard lock(mutex_);
  switch (id) {
    case ONI_STREAM_PROPERTY_VIDEO_MODE:
      return PutExactly(mode_, data, size);
    case ONI_STREAM_PROPERTY_HORIZONTAL_FOV:
      return PutReal(camera_.HorizontalFov(), data, size);
    case ONI_STREAM_PROPERTY_VERTICAL_FOV:
      return PutReal(camera_.VerticalFov(), data, size);
    case ONI_STREAM_PROPERTY_MAX_VALUE:
      return PutInteger(MaxValue(), data, size);
    case ONI_STREAM_PROPERTY_MIN_VALUE:
      return PutInteger(0, data, size);
    case ONI_STREAM_PROPERTY_STRIDE:
      return PutInteger(mode_.resolutionX * static_cast<int64_t>(BytesPerPixel(type_)), data, size);
    case ONI_STREAM_PROPERTY_MIRRORING:
      return PutExactly<OniBool>(mirror_ ? TRUE : FALSE, data, size);
    case ONI_STREAM_PROPERTY_CROPPING:
      // Without it, OpenNI2's recordings of the stream play back no frame (openni2.md 5.1).
      return PutExactly(OniCropping{.enabled = FALSE, .originX = 0, .originY = 0,
                                    .width = mode_.resolutionX, .height = mode_.resolutionY},
                        data, size);
    case XN_STREAM_PROPERTY_ZERO_PLANE_DISTANCE:
      if (!IsDepth(type_)) break;
      return PutInteger(static_cast<int64_t>(kZeroPlaneDistanceMm), data, size);
    case XN_STREAM_PROPERTY_ZERO_PLANE_PIXEL_SIZE: {
      if (!IsDepth(type_)) break;
      const double vga_focal_px = VirtualCameraFor(device_->sensor(), 640, 480).focal_px;
      return PutReal(kZeroPlaneDistanceMm / (2.0 * vga_focal_px), data, size);
    }
    case XN_STREAM_PROPERTY_EMITTER_DCMOS_DISTANCE:
      // cm between the illumination and the sensor: a time-of-flight camera's depth needs no
      // baseline, and transientd's depth is measured along the sensor's own rays.
      if (!IsDepth(type_)) break;
      return PutReal(0.0, data, size);
    default:
      break;
  }
  return ONI_STATUS_NOT_SUPPORTED;
}

OniStatus Stream::setProperty(int id, const void* data, int size) {
  if (data == nullptr) return ONI_STATUS_BAD_PARAMETER;
  std::lock_guard lock(mutex_);
  switch (id) {
    case ONI_STREAM_PROPERTY_VIDEO_MODE: {
      if (size != static_cast<int>(sizeof(OniVideoMode))) return ONI_STATUS_BAD_PARAMETER;
      OniVideoMode wanted;
      std::memcpy(&wanted, data, sizeof wanted);
      OniSensorInfo* infos = nullptr;
      int count = 0;
      device_->getSensorInfoList(&infos, &count);
      for (int s = 0; s < count; ++s) {
        if (infos[s].sensorType != type_) continue;
        for (int m = 0; m < infos[s].numSupportedVideoModes; ++m) {
          const OniVideoMode& offered = infos[s].pSupportedVideoModes[m];
          if (offered.pixelFormat == wanted.pixelFormat &&
              offered.resolutionX == wanted.resolutionX &&
              offered.resolutionY == wanted.resolutionY && offered.fps == wanted.fps) {
            mode_ = wanted;
            UpdateGeometry();
            return ONI_STATUS_OK;
          }
        }
      }
      device_->events().log(kLogWarning,
                            absl::StrCat("video mode ", wanted.resolutionX, "x",
                                         wanted.resolutionY, "@", wanted.fps, " format ",
                                         wanted.pixelFormat, " is not offered"));
      return ONI_STATUS_NOT_SUPPORTED;
    }
    case ONI_STREAM_PROPERTY_MIRRORING: {
      if (size != static_cast<int>(sizeof(OniBool))) return ONI_STATUS_BAD_PARAMETER;
      OniBool mirror;
      std::memcpy(&mirror, data, sizeof mirror);
      mirror_ = mirror != FALSE;
      return ONI_STATUS_OK;
    }
    case ONI_STREAM_PROPERTY_CROPPING: {
      if (size != static_cast<int>(sizeof(OniCropping))) return ONI_STATUS_BAD_PARAMETER;
      OniCropping cropping;
      std::memcpy(&cropping, data, sizeof cropping);
      return cropping.enabled ? ONI_STATUS_NOT_SUPPORTED : ONI_STATUS_OK;
    }
    default:
      return ONI_STATUS_NOT_SUPPORTED;
  }
}

void Stream::notifyAllProperties() {
  // What OpenNI2's Recorder stores with the stream (it asks before recording).
  for (const int id : {ONI_STREAM_PROPERTY_VIDEO_MODE, ONI_STREAM_PROPERTY_HORIZONTAL_FOV,
                       ONI_STREAM_PROPERTY_VERTICAL_FOV, ONI_STREAM_PROPERTY_MAX_VALUE,
                       ONI_STREAM_PROPERTY_MIN_VALUE, ONI_STREAM_PROPERTY_STRIDE,
                       ONI_STREAM_PROPERTY_MIRRORING, ONI_STREAM_PROPERTY_CROPPING}) {
    alignas(8) unsigned char value[64];
    int size = 0;
    switch (id) {
      case ONI_STREAM_PROPERTY_VIDEO_MODE:
        size = sizeof(OniVideoMode);
        break;
      case ONI_STREAM_PROPERTY_HORIZONTAL_FOV:
      case ONI_STREAM_PROPERTY_VERTICAL_FOV:
        size = sizeof(float);
        break;
      case ONI_STREAM_PROPERTY_MIRRORING:
        size = sizeof(OniBool);
        break;
      case ONI_STREAM_PROPERTY_CROPPING:
        size = sizeof(OniCropping);
        break;
      default:
        size = sizeof(int);
        break;
    }
    if (getProperty(id, value, &size) == ONI_STATUS_OK) raisePropertyChanged(id, value, size);
  }
}

void Stream::Raise(uint64_t frame_index, uint64_t timestamp_us, const std::vector<float>& image) {
  if (image.size() != static_cast<size_t>(device_->sensor().geometry.pixel_count())) return;
  OniFrame* frame = getServices().acquireFrame();
  if (frame == nullptr) return;  // the application's allocator had none
  {
    std::lock_guard lock(mutex_);
    const int width = mode_.resolutionX, height = mode_.resolutionY;
    const int bytes_per_pixel = BytesPerPixel(type_);
    const int bytes = width * height * bytes_per_pixel;
    if (frame->dataSize < bytes) {
      // Sized for an earlier, smaller mode (the core sizes its buffers when the stream starts).
      getServices().releaseFrame(frame);
      return;
    }
    const uint16_t max_count = MaxValue();
    const DepthUnit unit = UnitOf(mode_.pixelFormat);
    const double ir_scale = device_->uri().ir_scale;
    auto* out = static_cast<uint8_t*>(frame->data);
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u) {
        const int32_t from = map_[static_cast<size_t>(v) * width + u];
        uint8_t* pixel = out + (static_cast<size_t>(v) * width + (mirror_ ? width - 1 - u : u)) *
                                   bytes_per_pixel;
        if (type_ == ONI_SENSOR_COLOR) {
          // The amplitude as grey: red, green and blue alike.
          const uint8_t grey = from >= 0 ? GreyLevel(image[from], ir_scale) : 0;
          pixel[0] = pixel[1] = pixel[2] = grey;
          continue;
        }
        uint16_t value = 0;
        if (from >= 0) {
          value = IsDepth(type_) ? DepthCount(image[from], unit, max_count)
                                 : IrCount(image[from], ir_scale);
        }
        std::memcpy(pixel, &value, sizeof value);
      }
    }
    frame->dataSize = bytes;
    frame->sensorType = type_;
    frame->timestamp = timestamp_us;
    frame->frameIndex = static_cast<int>(frame_index);
    frame->videoMode = mode_;
    frame->width = width;
    frame->height = height;
    frame->stride = width * bytes_per_pixel;
    frame->croppingEnabled = FALSE;
    frame->cropOriginX = frame->cropOriginY = 0;
  }
  raiseNewFrame(frame);
  getServices().releaseFrame(frame);
}

// ---------------------------------------------------------------------------------------------
// Device

Device::Device(DeviceUri uri, client::Client client, v1::Info info, DeviceEvents events)
    : uri_(std::move(uri)),
      client_(std::move(client)),
      info_(std::move(info)),
      events_(std::move(events)),
      sensor_(SensorOf(info_)),
      max_depth_m_(info_.unambiguous_range_m()) {
  for (const int product : info_.products()) has_ir_ |= product == v1::AMPLITUDE;
  for (const auto& [width, height] : ModeSizes(sensor_, uri_)) {
    for (const OniPixelFormat format : {ONI_PIXEL_FORMAT_DEPTH_1_MM, ONI_PIXEL_FORMAT_DEPTH_100_UM}) {
      depth_modes_.push_back({.pixelFormat = format, .resolutionX = width, .resolutionY = height,
                              .fps = kModeFps});
    }
    ir_modes_.push_back({.pixelFormat = ONI_PIXEL_FORMAT_GRAY16, .resolutionX = width,
                         .resolutionY = height, .fps = kModeFps});
    color_modes_.push_back({.pixelFormat = ONI_PIXEL_FORMAT_RGB888, .resolutionX = width,
                            .resolutionY = height, .fps = kModeFps});
  }
  sensor_infos_.push_back({.sensorType = ONI_SENSOR_DEPTH,
                           .numSupportedVideoModes = static_cast<int>(depth_modes_.size()),
                           .pSupportedVideoModes = depth_modes_.data()});
  if (has_ir_) {
    sensor_infos_.push_back({.sensorType = ONI_SENSOR_IR,
                             .numSupportedVideoModes = static_cast<int>(ir_modes_.size()),
                             .pSupportedVideoModes = ir_modes_.data()});
    // The amplitude again, as the grey "colour" image that applications pair with depth
    // (RTAB-Map, PCL's frame rate); registered to depth by construction.
    sensor_infos_.push_back({.sensorType = ONI_SENSOR_COLOR,
                             .numSupportedVideoModes = static_cast<int>(color_modes_.size()),
                             .pSupportedVideoModes = color_modes_.data()});
  }
}

Device::~Device() {
  std::thread done;
  {
    std::lock_guard lock(mutex_);
    started_.clear();
    stopping_ = true;
    if (stream_ != nullptr) stream_->Cancel();
    done = std::move(receiver_);
  }
  cancel_connect_ = true;
  wake_.notify_all();
  if (done.joinable()) done.join();
}

OniStatus Device::getSensorInfoList(OniSensorInfo** sensors, int* count) {
  // Member storage: the core does not free it.
  *sensors = sensor_infos_.data();
  *count = static_cast<int>(sensor_infos_.size());
  return ONI_STATUS_OK;
}

oni::driver::StreamBase* Device::createStream(OniSensorType type) {
  if (type != ONI_SENSOR_DEPTH &&
      !((type == ONI_SENSOR_IR || type == ONI_SENSOR_COLOR) && has_ir_)) {
    return nullptr;
  }
  const int width = uri_.width == 0 ? sensor_.geometry.width : uri_.width;
  const int height = uri_.height == 0 ? sensor_.geometry.height : uri_.height;
  const OniPixelFormat format =
      type == ONI_SENSOR_IR      ? ONI_PIXEL_FORMAT_GRAY16
      : type == ONI_SENSOR_COLOR ? ONI_PIXEL_FORMAT_RGB888
      : uri_.unit == DepthUnit::kMillimetre ? ONI_PIXEL_FORMAT_DEPTH_1_MM
                                            : ONI_PIXEL_FORMAT_DEPTH_100_UM;
  return new Stream(this, type,
                    {.pixelFormat = format, .resolutionX = width, .resolutionY = height,
                     .fps = kModeFps});
}

void Device::destroyStream(oni::driver::StreamBase* stream) {
  auto* ours = static_cast<Stream*>(stream);
  StopStream(ours);
  delete ours;
}

OniBool Device::isPropertySupported(int id) {
  switch (id) {
    case ONI_DEVICE_PROPERTY_SERIAL_NUMBER:
    case ONI_DEVICE_PROPERTY_FIRMWARE_VERSION:
    case ONI_DEVICE_PROPERTY_DRIVER_VERSION:
    case ONI_DEVICE_PROPERTY_IMAGE_REGISTRATION:
      return TRUE;
    default:
      return FALSE;
  }
}

OniStatus Device::getProperty(int id, void* data, int* size) {
  if (data == nullptr || size == nullptr) return ONI_STATUS_BAD_PARAMETER;
  switch (id) {
    case ONI_DEVICE_PROPERTY_SERIAL_NUMBER:
      // The camera's serial when the source has one, else the daemon's address.
      return PutString(info_.camera().serial().empty() ? uri_.address : info_.camera().serial(),
                       data, size);
    case ONI_DEVICE_PROPERTY_FIRMWARE_VERSION:
      return PutString(absl::StrCat("transientd ", info_.version()), data, size);
    case ONI_DEVICE_PROPERTY_DRIVER_VERSION:
      return PutExactly(OniVersion{.major = 0, .minor = 1, .maintenance = 0, .build = 0}, data,
                        size);
    case ONI_DEVICE_PROPERTY_IMAGE_REGISTRATION:
      return PutExactly(registration_, data, size);
    default:
      return ONI_STATUS_NOT_SUPPORTED;
  }
}

OniStatus Device::setProperty(int id, const void* data, int size) {
  if (data == nullptr) return ONI_STATUS_BAD_PARAMETER;
  if (id != ONI_DEVICE_PROPERTY_IMAGE_REGISTRATION) return ONI_STATUS_NOT_SUPPORTED;
  if (size != static_cast<int>(sizeof(OniImageRegistrationMode))) return ONI_STATUS_BAD_PARAMETER;
  OniImageRegistrationMode mode;
  std::memcpy(&mode, data, sizeof mode);
  if (!isImageRegistrationModeSupported(mode)) return ONI_STATUS_NOT_SUPPORTED;
  registration_ = mode;
  return ONI_STATUS_OK;
}

OniBool Device::isImageRegistrationModeSupported(OniImageRegistrationMode mode) {
  // Depth and amplitude share the sensor's pixels: depth-to-"colour" is the identity.
  return mode == ONI_IMAGE_REGISTRATION_OFF || mode == ONI_IMAGE_REGISTRATION_DEPTH_TO_COLOR
             ? TRUE
             : FALSE;
}

void Device::StartStream(Stream* stream) {
  std::lock_guard lock(mutex_);
  started_.insert(stream);
  if (!receiver_.joinable()) {
    stopping_ = false;
    cancel_connect_ = false;
    receiver_ = std::thread(&Device::Receive, this);
  }
}

void Device::StopStream(Stream* stream) {
  std::thread done;
  {
    // Frames are raised under this lock: once the stream is out of started_, none follows.
    std::lock_guard lock(mutex_);
    started_.erase(stream);
    if (!started_.empty() || !receiver_.joinable()) return;
    stopping_ = true;
    if (stream_ != nullptr) stream_->Cancel();
    done = std::move(receiver_);
  }
  cancel_connect_ = true;
  wake_.notify_all();
  done.join();
}

void Device::Deliver(uint64_t sequence, double capture_time_s, const client::StreamFrame& frame) {
  const std::vector<float>* depth = nullptr;
  const std::vector<float>* amplitude = nullptr;
  for (const client::DecodedImage& image : frame.images) {
    if (image.product == v1::DEPTH) depth = &image.values;
    if (image.product == v1::AMPLITUDE) amplitude = &image.values;
  }
  uint64_t timestamp_us = static_cast<uint64_t>(std::llround(std::max(0.0, capture_time_s) * 1e6));
  std::lock_guard lock(mutex_);
  timestamp_us += timestamp_offset_us_;
  if (last_timestamp_us_ != 0 && timestamp_us <= last_timestamp_us_) {
    // The daemon restarted its source: keep the device's clock monotonic.
    timestamp_offset_us_ += last_timestamp_us_ + kRestartGapUs - timestamp_us;
    timestamp_us = last_timestamp_us_ + kRestartGapUs;
  }
  last_timestamp_us_ = timestamp_us;
  for (Stream* stream : started_) {
    const std::vector<float>* image = IsDepth(stream->type()) ? depth : amplitude;
    if (image != nullptr) stream->Raise(sequence, timestamp_us, *image);
  }
}

void Device::Receive() {
  v1::StreamRequest request;
  request.add_products(v1::DEPTH);
  if (has_ir_) request.add_products(v1::AMPLITUDE);
  std::optional<client::Client> reconnected;  // after the daemon was lost
  bool lost = false;
  while (true) {
    const client::Client& daemon = reconnected ? *reconnected : client_;
    std::unique_ptr<client::FrameStream> frames = daemon.StreamFrames(request);
    {
      std::lock_guard lock(mutex_);
      if (stopping_) return;
      stream_ = frames.get();
    }
    client::StreamFrame frame;
    while (frames->Next(&frame)) {
      if (frame.kind != client::StreamFrame::Kind::kImages) continue;
      if (lost) {
        lost = false;
        events_.log(kLogInfo, absl::StrCat(uri_.uri, ": transientd is back"));
        events_.state_changed(uri_.uri, ONI_DEVICE_STATE_OK);
      }
      Deliver(frame.sequence, frame.capture_time_s, frame);
    }
    const absl::Status end = frames->Finish();
    {
      std::lock_guard lock(mutex_);
      stream_ = nullptr;
      if (stopping_) return;
    }
    if (!lost) {
      // The daemon stopped, was lost or refused: the streams pause until it answers again.
      lost = true;
      events_.log(kLogWarning, absl::StrCat(uri_.uri, ": the frame stream ended (",
                                            end.ok() ? "by the daemon" : end.ToString(),
                                            "); reconnecting"));
      events_.state_changed(uri_.uri, ONI_DEVICE_STATE_ERROR);
    }
    {
      std::unique_lock lock(mutex_);
      wake_.wait_for(lock, std::chrono::milliseconds(500), [this] { return stopping_; });
      if (stopping_) return;
    }
    absl::StatusOr<client::Client> again =
        client::Client::Connect({.address = uri_.address,
                                 .security = SecurityFromEnvironment(),
                                 .timeout_s = 1.0,
                                 .cancel = &cancel_connect_});
    if (again.ok()) reconnected.emplace(*std::move(again));
  }
}

}  // namespace transient::openni2
