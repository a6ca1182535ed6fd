// The openni2: source (openni2_source.cc): depth from an OpenNI2 device or .oni recording.
#pragma once

#include <memory>
#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "transient/drivers/capture_devices.h"
#include "transient/drivers/capture_source.h"
#include "transient/drivers/source_registry.h"

namespace transient::openni2 {

// openni2:<device URI, or an .oni path; empty: the first device>?pace=&loop=&fx=&fy=&cx=&cy=.
// InvalidArgument for a bad key or a transient:// URI (transientd's own OpenNI2 device);
// NotFound when OpenNI2 cannot open the device or file; DataLoss for a recording without depth.
absl::StatusOr<std::unique_ptr<CaptureSource>> OpenOpenNi2Source(absl::string_view uri);
std::span<const SourceKey> OpenNi2Keys();

// The devices OpenNI2 enumerates (its USB drivers' cameras), for transient devices.
std::vector<CaptureDevice> ListOpenNi2Devices();

}  // namespace transient::openni2
