// WithContext: the one way a status gains context on its way up.
#include "transient/reconstruct/status_context.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/support/status_matchers.h"

namespace transient {
namespace {

using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

TEST(WithContext, PrefixesTheMessageAndKeepsTheCode) {
  const absl::Status inner = absl::DataLossError("/frames/pixels: cannot read frame 7");
  EXPECT_THAT(WithContext("capture.h5", inner),
              StatusIs(absl::StatusCode::kDataLoss,
                       "capture.h5: /frames/pixels: cannot read frame 7"));
  // Contexts nest from the outside in.
  EXPECT_THAT(WithContext("--input", WithContext("capture.h5", inner)),
              StatusIs(absl::StatusCode::kDataLoss,
                       "--input: capture.h5: /frames/pixels: cannot read frame 7"));
}

TEST(WithContext, LeavesOkAlone) {
  EXPECT_THAT(WithContext("capture.h5", absl::OkStatus()), IsOk());
}

}  // namespace
}  // namespace transient
