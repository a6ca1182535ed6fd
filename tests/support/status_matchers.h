// gMock matchers for absl::Status (Debian's Abseil ships no status_matchers.h):
// EXPECT_THAT(status, IsOk()); EXPECT_THAT(status, StatusIs(code, HasSubstr("...")));
// EXPECT_THAT(status_or, IsOkAndHolds(ElementsAre(1, 2))).
#pragma once

#include <gmock/gmock.h>

#include <string>
#include <type_traits>

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

// An absl::StatusOr<T> that is OK and whose value matches `value_matcher`.
MATCHER_P(IsOkAndHolds, value_matcher,
          "is OK and holds a value that " +
              ::testing::DescribeMatcher<typename std::remove_cvref_t<arg_type>::value_type>(
                  value_matcher)) {
  if (!arg.ok()) {
    *result_listener << "status " << arg.status();
    return false;
  }
  return ::testing::ExplainMatchResult(value_matcher, *arg, result_listener);
}

}  // namespace transient::testing
