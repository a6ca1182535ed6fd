// One transientd as an OpenNI2 device: its depth, IR and colour (both amplitude) sensors, their
// streams, and the thread that receives the daemon's frames and hands them to the started streams
// (../shared/research/openni2.md, section 6.1; the driver API is Driver/OniDriverAPI.h).
#pragma once

#include <Driver/OniDriverAPI.h>

#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "device_uri.h"
#include "transient/client/client.h"
#include "transient/openni2/oni_frames.h"
#include "transient/reconstruct/camera_model.h"

namespace transient::openni2 {

class Device;

// OpenNI2's log severities (XnLog.h, which its public headers do not include), for
// DeviceEvents::log and the driver's own lines.
inline constexpr int kLogInfo = 1;
inline constexpr int kLogWarning = 2;

// What a device tells its driver: a log line, and a change of its state (OpenNI2's
// deviceStateChanged: ONI_DEVICE_STATE_ERROR when the daemon is lost, OK when it is back).
struct DeviceEvents {
  std::function<void(int severity, const std::string& message)> log;
  std::function<void(const std::string& uri, OniDeviceState state)> state_changed;
};

// A depth, IR (GRAY16 amplitude) or colour (RGB888 grey amplitude) stream. Properties: VIDEO_MODE (get, set), HORIZONTAL_FOV, VERTICAL_FOV,
// MAX_VALUE, MIN_VALUE, STRIDE, MIRRORING (get, set), CROPPING (get; set only to disabled), and
// PS1080's ZERO_PLANE_DISTANCE, ZERO_PLANE_PIXEL_SIZE, EMITTER_DCMOS_DISTANCE (get), integers
// as 4 or 8 bytes. Anything else is ONI_STATUS_NOT_SUPPORTED.
class Stream : public oni::driver::StreamBase {
 public:
  Stream(Device* device, OniSensorType type, const OniVideoMode& mode);

  OniStatus start() override;
  void stop() override;  // after it returns, no frame of this stream is raised
  OniStatus setProperty(int id, const void* data, int size) override;
  OniStatus getProperty(int id, void* data, int* size) override;
  OniBool isPropertySupported(int id) override;
  void notifyAllProperties() override;

  OniSensorType type() const { return type_; }
  // Fills and raises one frame from the sensor's depth (metres) or amplitude image; called by
  // the device's receiver while the stream is started.
  void Raise(uint64_t frame_index, uint64_t timestamp_us, const std::vector<float>& image);

 private:
  // The virtual camera and resampling map of mode_ (oni_frames.h).
  void UpdateGeometry();
  uint16_t MaxValue() const;

  Device* const device_;
  const OniSensorType type_;
  std::mutex mutex_;  // mode_, camera_, map_, mirror_ (the receiver reads them in Raise)
  OniVideoMode mode_;
  VirtualCamera camera_;
  std::vector<int32_t> map_;
  bool mirror_ = false;
};

class Device : public oni::driver::DeviceBase {
 public:
  // `info` is the daemon's GetInfo at opening.
  Device(DeviceUri uri, client::Client client, v1::Info info, DeviceEvents events);
  ~Device() override;

  OniStatus getSensorInfoList(OniSensorInfo** sensors, int* count) override;
  oni::driver::StreamBase* createStream(OniSensorType type) override;
  void destroyStream(oni::driver::StreamBase* stream) override;
  OniStatus setProperty(int id, const void* data, int size) override;
  OniStatus getProperty(int id, void* data, int* size) override;
  OniBool isPropertySupported(int id) override;
  OniBool isImageRegistrationModeSupported(OniImageRegistrationMode mode) override;

  const DeviceUri& uri() const { return uri_; }
  const CameraInfo& sensor() const { return sensor_; }
  double max_depth_m() const { return max_depth_m_; }
  const DeviceEvents& events() const { return events_; }

  // The receiver runs while at least one stream is started; StopStream joins it when the last
  // one stops.
  void StartStream(Stream* stream);
  void StopStream(Stream* stream);

 private:
  void Receive();
  // One frame of the daemon to every started stream.
  void Deliver(uint64_t sequence, double capture_time_s, const client::StreamFrame& frame);

  const DeviceUri uri_;
  const client::Client client_;
  const v1::Info info_;
  const DeviceEvents events_;
  CameraInfo sensor_;
  double max_depth_m_ = 0.0;
  bool has_ir_ = false;
  std::vector<OniVideoMode> depth_modes_, ir_modes_, color_modes_;
  std::vector<OniSensorInfo> sensor_infos_;
  OniImageRegistrationMode registration_ = ONI_IMAGE_REGISTRATION_OFF;

  std::mutex mutex_;  // started_, stream_, stopping_; held while frames are raised
  std::condition_variable wake_;
  std::set<Stream*> started_;
  client::FrameStream* stream_ = nullptr;  // the receiver's current subscription
  bool stopping_ = false;
  std::atomic<bool> cancel_connect_{false};  // interrupts the receiver's reconnecting
  std::thread receiver_;
  // Timestamps stay monotonic across a daemon's restart: added to its capture times.
  uint64_t timestamp_offset_us_ = 0;
  uint64_t last_timestamp_us_ = 0;
};

}  // namespace transient::openni2
