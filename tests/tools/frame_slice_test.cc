// --frames parses Python slices and resolves them strictly against the file's frame count.
#include "tools/transient/common/frame_slice.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/support/status_matchers.h"

namespace transient::tools {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

FrameRange Resolve(absl::string_view text, int64_t frames) {
  absl::StatusOr<FrameSlice> slice = ParseFrameSlice(text);
  EXPECT_THAT(slice.status(), IsOk()) << text;
  absl::StatusOr<FrameRange> range = ResolveFrameSlice(slice.value_or(FrameSlice{}), frames);
  EXPECT_THAT(range.status(), IsOk()) << text;
  return range.value_or(FrameRange{.first = -1, .count = -1});
}

TEST(FrameSlice, EitherSideMayBeOmitted) {
  EXPECT_EQ(Resolve(":", 10), (FrameRange{.first = 0, .count = 10}));
  EXPECT_EQ(Resolve("3:", 10), (FrameRange{.first = 3, .count = 7}));
  EXPECT_EQ(Resolve(":4", 10), (FrameRange{.first = 0, .count = 4}));
  EXPECT_EQ(Resolve("2:5", 10), (FrameRange{.first = 2, .count = 3}));
}

TEST(FrameSlice, NegativeIndicesCountFromTheEndAsInPython) {
  EXPECT_EQ(Resolve("-2:", 10), (FrameRange{.first = 8, .count = 2}));
  EXPECT_EQ(Resolve(":-1", 10), (FrameRange{.first = 0, .count = 9}));
  EXPECT_EQ(Resolve("-10:+10", 10), (FrameRange{.first = 0, .count = 10}));
}

TEST(FrameSlice, DefaultSliceSelectsEveryFrame) {
  absl::StatusOr<FrameRange> range = ResolveFrameSlice(FrameSlice{}, 3);
  ASSERT_THAT(range.status(), IsOk());
  EXPECT_EQ(*range, (FrameRange{.first = 0, .count = 3}));
}

TEST(FrameSlice, TextThatIsNotASliceIsRejected) {
  for (absl::string_view text : {"", "3", "1:2:3", "a:b", "1.5:", ":x", "- 1:", "--1:"}) {
    EXPECT_THAT(ParseFrameSlice(text).status(),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("expected A:B")))
        << "'" << text << "'";
  }
}

TEST(FrameSlice, IndicesOutsideTheFileAreRejectedRatherThanClamped) {
  EXPECT_THAT(ResolveFrameSlice({.start = 0, .stop = 11}, 10).status(),
              StatusIs(absl::StatusCode::kOutOfRange,
                       HasSubstr("--frames = '0:11' of 10 frames: stop 11 is outside -10..10")));
  EXPECT_THAT(ResolveFrameSlice({.start = -11}, 10).status(),
              StatusIs(absl::StatusCode::kOutOfRange, HasSubstr("start -11 is outside")));
}

TEST(FrameSlice, EmptySelectionIsRejected) {
  EXPECT_THAT(ResolveFrameSlice({.start = 5, .stop = 5}, 10).status(),
              StatusIs(absl::StatusCode::kOutOfRange, HasSubstr("selects no frames")));
  EXPECT_THAT(ResolveFrameSlice({.start = -1, .stop = 2}, 10).status(),
              StatusIs(absl::StatusCode::kOutOfRange, HasSubstr("selects no frames")));
}

}  // namespace
}  // namespace transient::tools
