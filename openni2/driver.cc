// libtransient-openni2.so.0: transientd as an OpenNI2 camera. OpenNI2 loads it from the
// OpenNI2/Drivers folder beside libOpenNI2.so.0 and calls the 33 oniDriver* functions that
// ONI_EXPORT_DRIVER defines (the only symbols it exports: openni2.map). openni2/README.md says
// how to install and use it; ../shared/research/openni2.md has the facts behind each choice.
#include <Driver/OniDriverAPI.h>

#include <cstdlib>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "device.h"
#include "device_uri.h"
#include "transient/client/client.h"
#include "transient/wire/address.h"

namespace transient::openni2 {
namespace {

// How long initialize() waits for the default daemon: OpenNI2 initialises every driver in its
// folder in every program that opens a camera, so a daemon that is not running must cost them
// no more than this.
constexpr double kProbeTimeoutS = 0.2;
// How long tryDevice and deviceOpen wait for a daemon the application named.
constexpr double kOpenTimeoutS = 2.0;

// The daemon at `address` and its GetInfo within `timeout_s`.
struct Probe {
  client::Client client;
  v1::Info info;
};
absl::StatusOr<Probe> ProbeDaemon(const std::string& address, double timeout_s) {
  absl::StatusOr<client::Client> daemon =
      client::Client::Connect({.address = address,
                               .security = SecurityFromEnvironment(),
                               .timeout_s = timeout_s,
                               .call_timeout_s = timeout_s});
  if (!daemon.ok()) return daemon.status();
  absl::StatusOr<v1::Info> info = daemon->GetInfo();
  if (!info.ok()) return info.status();
  return Probe{*std::move(daemon), *std::move(info)};
}

class Driver : public oni::driver::DriverBase {
 public:
  explicit Driver(OniDriverServices* services) : DriverBase(services) {}

  OniStatus initialize(oni::driver::DeviceConnectedCallback connected,
                       oni::driver::DeviceDisconnectedCallback disconnected,
                       oni::driver::DeviceStateChangedCallback state_changed,
                       void* cookie) override {
    const OniStatus status = DriverBase::initialize(connected, disconnected, state_changed, cookie);
    if (status != ONI_STATUS_OK) return status;
    // transientd sets it for its own OpenNI2 input: a daemon must not open itself as a camera.
    disabled_ = std::getenv("TRANSIENT_OPENNI2_DISABLE") != nullptr;
    if (disabled_) return ONI_STATUS_OK;
    const char* address = std::getenv("TRANSIENT_OPENNI2_ADDRESS");
    const std::string target = address != nullptr && *address != '\0' ? address : wire::kDefaultAddress;
    // Announced only when a daemon answers: OpenNI2 opens the first announced device for
    // "any device", and a device without a daemon would take that place from a real camera.
    absl::StatusOr<Probe> probe = ProbeDaemon(target, kProbeTimeoutS);
    if (probe.ok()) {
      Announce(DeviceUriOf(target), probe->info);
    } else {
      Log(kLogInfo, absl::StrCat("no transientd at ", target, ": ", probe.status().message()));
    }
    return ONI_STATUS_OK;
  }

  // OpenNI2 offers every URI no driver announced to every driver: ours are transient://.
  OniStatus tryDevice(const char* uri) override {
    if (disabled_ || uri == nullptr) return ONI_STATUS_ERROR;
    absl::StatusOr<DeviceUri> parsed = ParseDeviceUri(uri);
    if (!parsed.ok()) {
      if (!absl::IsNotFound(parsed.status())) Log(kLogWarning, parsed.status().ToString());
      return ONI_STATUS_ERROR;
    }
    absl::StatusOr<Probe> probe = ProbeDaemon(parsed->address, kOpenTimeoutS);
    if (!probe.ok()) {
      Log(kLogWarning, absl::StrCat(uri, ": ", probe.status().ToString()));
      return ONI_STATUS_ERROR;
    }
    Announce(uri, probe->info);
    return ONI_STATUS_OK;
  }

  oni::driver::DeviceBase* deviceOpen(const char* uri, const char* /*mode*/) override {
    if (disabled_ || uri == nullptr) return nullptr;
    absl::StatusOr<DeviceUri> parsed = ParseDeviceUri(uri);
    if (!parsed.ok()) {
      Log(kLogWarning, parsed.status().ToString());
      return nullptr;
    }
    absl::StatusOr<Probe> probe = ProbeDaemon(parsed->address, kOpenTimeoutS);
    if (!probe.ok()) {
      Log(kLogWarning, absl::StrCat(uri, ": ", probe.status().ToString()));
      return nullptr;
    }
    DeviceEvents events{
        .log = [this](int severity, const std::string& message) { Log(severity, message); },
        .state_changed =
            [this, name = NameOf(probe->info)](const std::string& device_uri,
                                               OniDeviceState state) {
              OniDeviceInfo info = InfoOf(device_uri, name);
              deviceStateChanged(&info, state);
            }};
    return new Device(*std::move(parsed), std::move(probe->client), std::move(probe->info),
                      std::move(events));
  }

  void deviceClose(oni::driver::DeviceBase* device) override { delete device; }

  void shutdown() override {}

  // Frames of one capture share their index and timestamp, by which OpenNI2 pairs them: a
  // group needs no more than a handle.
  void* enableFrameSync(oni::driver::StreamBase** /*streams*/, int /*count*/) override {
    return new int(0);
  }
  void disableFrameSync(void* group) override { delete static_cast<int*>(group); }

 private:
  // The device's name: the daemon and its camera.
  static std::string NameOf(const v1::Info& info) {
    return absl::StrCat("transientd (", info.camera().model(), ")");
  }

  static OniDeviceInfo InfoOf(const std::string& uri, const std::string& name) {
    OniDeviceInfo info{};
    absl::SNPrintF(info.uri, sizeof info.uri, "%s", uri);
    absl::SNPrintF(info.vendor, sizeof info.vendor, "%s", "transient");
    absl::SNPrintF(info.name, sizeof info.name, "%s", name);
    return info;
  }

  void Announce(const std::string& uri, const v1::Info& info) {
    OniDeviceInfo device = InfoOf(uri, NameOf(info));
    deviceConnected(&device);
    Log(kLogInfo, absl::StrCat("announced ", uri, ": ", info.source_uri()));
  }

  void Log(int severity, const std::string& message) {
    getServices().log(severity, __FILE__, __LINE__, "transient", message.c_str());
  }

  bool disabled_ = false;
};

}  // namespace
}  // namespace transient::openni2

// ONI_EXPORT_DRIVER creates the driver with XnLib's allocation macros, which the public headers
// do not define.
#define XN_NEW(type, arg) new type(arg)
#define XN_DELETE(p) delete (p)
ONI_EXPORT_DRIVER(transient::openni2::Driver)
