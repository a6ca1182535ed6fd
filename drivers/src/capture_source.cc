// OpenSource: picks the source implementation by the URI's scheme.
#include "transient/drivers/capture_source.h"

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "source_openers.h"

namespace transient {

absl::StatusOr<std::unique_ptr<CaptureSource>> OpenSource(absl::string_view uri) {
  if (absl::StartsWith(uri, "sim:")) return internal::OpenSimulatorSource(uri);
  if (absl::StartsWith(uri, "replay:")) return internal::OpenReplaySource(uri);
  return absl::InvalidArgumentError(
      absl::StrCat("unknown source '", uri,
                   "'; expected sim:<scene>?key=value&... or replay:<file.h5>?loop=1&pace=fast"));
}

}  // namespace transient
