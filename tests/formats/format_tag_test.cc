// The root `format` attribute: a known name and major version, any minor version.
#include "transient/formats/format_tag.h"

#include <optional>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "transient/formats/h5.h"

namespace transient::tools {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;
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

TEST(FormatTag, ParsesNameMajorAndMinorVersion) {
  std::optional<FormatTag> tag = ParseFormatTag("transient-moments 1");
  ASSERT_TRUE(tag.has_value());
  EXPECT_EQ(tag->name, "transient-moments");
  EXPECT_EQ(tag->major, 1);
  EXPECT_EQ(tag->minor, 0);
  tag = ParseFormatTag("netcdf 4.12");
  ASSERT_TRUE(tag.has_value());
  EXPECT_EQ(tag->name, "netcdf");
  EXPECT_EQ(tag->major, 4);
  EXPECT_EQ(tag->minor, 12);
  for (absl::string_view text : {"", "transient-moments", "transient-moments 1 2",
                                 "transient-moments 1.", "transient-moments .1",
                                 "transient-moments 99999999999"}) {
    EXPECT_FALSE(ParseFormatTag(text).has_value()) << "'" << text << "'";
  }
}

TEST(FormatTag, TheAttributeWrittenIsTheAttributeRead) {
  ScratchDirectory scratch;
  h5::SilenceErrorStack();
  h5::Id file = h5::File(H5Fcreate(scratch.File("f.h5").c_str(), H5F_ACC_TRUNC, H5P_DEFAULT,
                                   H5P_DEFAULT));
  ASSERT_TRUE(file.valid());
  EXPECT_THAT(ReadFormatAttribute(file.get(), "f.h5: /", "transient-moments", 1),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("f.h5: /: missing attribute format")));
  ASSERT_THAT(WriteFormatAttribute(file.get(), "transient-moments", 1), IsOk());
  EXPECT_EQ(*h5::ReadStringAttribute(file.get(), "format", "f.h5: /"), "transient-moments 1");
  EXPECT_THAT(ReadFormatAttribute(file.get(), "f.h5: /", "transient-moments", 1), IsOk());
  EXPECT_THAT(ReadFormatAttribute(file.get(), "f.h5: /", "transient-moments", 2),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("f.h5: /: attribute format: expected 'transient-moments 2', "
                                 "found 'transient-moments 1' (unsupported major version 1)")));
  EXPECT_THAT(ReadFormatAttribute(file.get(), "f.h5: /", "transient-capture", 1),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("(not a transient-capture file)")));
  ASSERT_THAT(h5::WriteDoubleAttribute(file.get(), "format", 1.0), IsOk());
  EXPECT_THAT(ReadFormatAttribute(file.get(), "f.h5: /", "transient-moments", 1),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("f.h5: /: attribute format: expected a string, found float64")));
}

}  // namespace
}  // namespace transient::tools
