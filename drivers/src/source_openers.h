// The openers OpenSource dispatches to, one per URI scheme. Each takes the whole URI.
#pragma once

#include <memory>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "transient/drivers/capture_source.h"

namespace transient::internal {

// "sim:<scene>?key=value&..." (src/sim/).
absl::StatusOr<std::unique_ptr<CaptureSource>> OpenSimulatorSource(absl::string_view uri);
// "replay:<path>?loop=1&pace=realtime|fast" (src/files/).
absl::StatusOr<std::unique_ptr<CaptureSource>> OpenReplaySource(absl::string_view uri);

}  // namespace transient::internal
