// gMock matchers for absl::Status (Debian's Abseil ships no status_matchers.h):
// EXPECT_THAT(status, IsOk()); EXPECT_THAT(status, StatusIs(code, HasSubstr("...")));
#pragma once

#include <gmock/gmock.h>

#include <string>

#include "absl/status/status.h"

namespace transient::testing {

MATCHER(IsOk, "is OK") {
  *result_listener << "status " << arg;
  return arg.ok();
}

MATCHER_P2(StatusIs, code, message_matcher,
           "has code " + ::testing::PrintToString(code) + " and a message that " +
               ::testing::DescribeMatcher<std::string>(message_matcher)) {
  const absl::Status& status = arg;
  *result_listener << "status " << status;
  return status.code() == code &&
         ::testing::Matches(message_matcher)(std::string(status.message()));
}

}  // namespace transient::testing
