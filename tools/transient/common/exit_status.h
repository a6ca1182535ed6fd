// How the command line reports a status: the exit code and the one-line error message.
#pragma once

#include <string>

#include "absl/status/status.h"

namespace transient::tools {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;        // the run failed for a reason outside the input
inline constexpr int kExitBadInput = 2;       // bad options, bad input file, unusable output path
inline constexpr int kExitInterrupted = 130;  // SIGINT/SIGTERM (128 + SIGINT, as shells do)

// kExitOk for OK; kExitInterrupted for Cancelled; kExitFailure for what the user cannot fix
// by changing the input or the options (Internal, Unknown, Unavailable, ResourceExhausted
// ...); kExitBadInput otherwise (DataLoss is a corrupt input file).
int ExitCodeFor(const absl::Status& status);

// "error: <message>" on one line: any line break in the message becomes a space.
std::string ErrorLine(const absl::Status& status);

}  // namespace transient::tools
