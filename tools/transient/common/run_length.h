// How long a command that receives frames runs: --frames N or --seconds S, exactly one of them
// (`transient record`, `transient client`).
#pragma once

#include <cmath>
#include <cstdint>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace transient::tools {

// frames >= 0, seconds finite and >= 0, and exactly one of them > 0. InvalidArgument naming the
// option and the rule.
inline absl::Status ValidateRunLength(int64_t frames, double seconds) {
  if (frames < 0) {
    return absl::InvalidArgumentError(absl::StrCat("--frames = ", frames, ": expected >= 1"));
  }
  if (!(seconds >= 0.0) || !std::isfinite(seconds)) {
    return absl::InvalidArgumentError(absl::StrCat("--seconds = ", seconds, ": expected > 0"));
  }
  if ((frames > 0) == (seconds > 0.0)) {
    return absl::InvalidArgumentError("give exactly one of --frames N and --seconds S");
  }
  return absl::OkStatus();
}

}  // namespace transient::tools
