// Parsing and resolution of --frames slices.
#include "tools/transient/common/frame_slice.h"

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"

namespace transient::tools {
namespace {

// An optional integer: empty text is "not given"; otherwise an optional sign and digits only.
absl::StatusOr<std::optional<int64_t>> ParseIndex(absl::string_view text) {
  if (text.empty()) return std::optional<int64_t>();
  absl::string_view digits = text;
  if (!absl::ConsumePrefix(&digits, "-")) absl::ConsumePrefix(&digits, "+");
  int64_t value = 0;
  if (digits.empty() || digits.find_first_not_of("0123456789") != absl::string_view::npos ||
      !absl::SimpleAtoi(text, &value)) {
    return absl::InvalidArgumentError(absl::StrCat("'", text, "' is not an integer"));
  }
  return std::optional<int64_t>(value);
}

}  // namespace

std::string FrameSlice::ToString() const {
  return absl::StrCat(start.has_value() ? absl::StrCat(*start) : "", ":",
                      stop.has_value() ? absl::StrCat(*stop) : "");
}

absl::StatusOr<FrameSlice> ParseFrameSlice(absl::string_view text) {
  const auto invalid = [&](absl::string_view why) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--frames = '", text, "': expected A:B, A:, :B or : (a Python slice of frame indices)",
        why.empty() ? "" : "; ", why));
  };
  const size_t colon = text.find(':');
  if (colon == absl::string_view::npos || text.find(':', colon + 1) != absl::string_view::npos) {
    return invalid("");
  }
  absl::StatusOr<std::optional<int64_t>> start = ParseIndex(text.substr(0, colon));
  if (!start.ok()) return invalid(start.status().message());
  absl::StatusOr<std::optional<int64_t>> stop = ParseIndex(text.substr(colon + 1));
  if (!stop.ok()) return invalid(stop.status().message());
  return FrameSlice{.start = *start, .stop = *stop};
}

absl::StatusOr<FrameRange> ResolveFrameSlice(const FrameSlice& slice, int64_t frame_count) {
  const std::string where =
      absl::StrCat("--frames = '", slice.ToString(), "' of ", frame_count, " frames: ");
  const auto resolve = [&](std::optional<int64_t> index, int64_t fallback,
                           const char* name) -> absl::StatusOr<int64_t> {
    if (!index.has_value()) return fallback;
    if (*index < -frame_count || *index > frame_count) {
      return absl::OutOfRangeError(
          absl::StrCat(where, name, " ", *index, " is outside ", -frame_count, "..", frame_count));
    }
    return *index < 0 ? *index + frame_count : *index;
  };
  absl::StatusOr<int64_t> first = resolve(slice.start, 0, "start");
  if (!first.ok()) return first.status();
  absl::StatusOr<int64_t> end = resolve(slice.stop, frame_count, "stop");
  if (!end.ok()) return end.status();
  if (*end <= *first) {
    return absl::OutOfRangeError(absl::StrCat(where, "selects no frames"));
  }
  return FrameRange{.first = *first, .count = *end - *first};
}

}  // namespace transient::tools
