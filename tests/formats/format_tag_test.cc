// The root `format` attribute: a known name and major version, any minor version.
#include "transient/formats/format_tag.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/support/status_matchers.h"

namespace transient::tools {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

TEST(FormatTag, AcceptsTheMajorVersionWithOrWithoutAMinorVersion) {
  EXPECT_THAT(CheckFormatTag("transient-moments 1", "transient-moments", 1), IsOk());
  EXPECT_THAT(CheckFormatTag("transient-moments 1.0", "transient-moments", 1), IsOk());
  EXPECT_THAT(CheckFormatTag("transient-moments 1.12", "transient-moments", 1), IsOk());
}

TEST(FormatTag, RejectsAnotherMajorVersion) {
  EXPECT_THAT(CheckFormatTag("transient-moments 2", "transient-moments", 1),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("expected 'transient-moments 1', found 'transient-moments 2' "
                                 "(unsupported major version 2)")));
  EXPECT_THAT(CheckFormatTag("transient-moments 0.9", "transient-moments", 1),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("major version 0")));
}

TEST(FormatTag, RejectsAnotherName) {
  EXPECT_THAT(
      CheckFormatTag("transient-reconstruction 1", "transient-moments", 1),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("(not a transient-moments file)")));
}

TEST(FormatTag, RejectsMalformedTags) {
  for (absl::string_view text :
       {"", "transient-moments", "transient-moments  1", "transient-moments v1",
        "transient-moments 1.", "transient-moments 1.2.3", " transient-moments 1",
        "transient-moments -1"}) {
    EXPECT_THAT(CheckFormatTag(text, "transient-moments", 1),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("NAME MAJOR[.MINOR]")))
        << "'" << text << "'";
  }
}

TEST(FormatTag, WritesNameAndMajorVersion) {
  EXPECT_EQ(FormatTagString("transient-reconstruction", 1), "transient-reconstruction 1");
}

}  // namespace
}  // namespace transient::tools
