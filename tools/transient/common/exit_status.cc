// Status to exit code and message.
#include "tools/transient/common/exit_status.h"

#include "absl/strings/str_cat.h"

namespace transient::tools {

int ExitCodeFor(const absl::Status& status) {
  switch (status.code()) {
    case absl::StatusCode::kOk:
      return kExitOk;
    case absl::StatusCode::kCancelled:
      return kExitInterrupted;
    case absl::StatusCode::kInvalidArgument:
    case absl::StatusCode::kNotFound:
    case absl::StatusCode::kAlreadyExists:
    case absl::StatusCode::kPermissionDenied:
    case absl::StatusCode::kFailedPrecondition:
    case absl::StatusCode::kOutOfRange:
    case absl::StatusCode::kDataLoss:  // a corrupt input file
      return kExitBadInput;
    default:
      return kExitFailure;
  }
}

std::string ErrorLine(const absl::Status& status) {
  std::string message(status.message());
  std::replace_if(
      message.begin(), message.end(), [](char c) { return c == '\n' || c == '\r'; }, ' ');
  return absl::StrCat("error: ", message);
}

}  // namespace transient::tools
