// The command line's exit codes and its one-line error messages.
#include "tools/transient/common/exit_status.h"

#include <gtest/gtest.h>

namespace transient::tools {
namespace {

TEST(ExitStatus, BadInputOfAnyKindExitsWithTwo) {
  EXPECT_EQ(ExitCodeFor(absl::InvalidArgumentError("")), kExitBadInput);
  EXPECT_EQ(ExitCodeFor(absl::NotFoundError("")), kExitBadInput);
  EXPECT_EQ(ExitCodeFor(absl::PermissionDeniedError("")), kExitBadInput);
  EXPECT_EQ(ExitCodeFor(absl::OutOfRangeError("")), kExitBadInput);
  EXPECT_EQ(ExitCodeFor(absl::DataLossError("")), kExitBadInput);
  EXPECT_EQ(kExitBadInput, 2);
}

TEST(ExitStatus, SuccessInterruptionAndInternalFailuresHaveTheirOwnCodes) {
  EXPECT_EQ(ExitCodeFor(absl::OkStatus()), 0);
  EXPECT_EQ(ExitCodeFor(absl::CancelledError("")), 130);
  EXPECT_EQ(ExitCodeFor(absl::InternalError("")), 1);
  EXPECT_EQ(ExitCodeFor(absl::UnavailableError("disk full")), 1);
}

TEST(ExitStatus, ErrorLineIsOneLine) {
  EXPECT_EQ(ErrorLine(absl::InvalidArgumentError("in.h5: bad\nthing")), "error: in.h5: bad thing");
}

}  // namespace
}  // namespace transient::tools
