// The --frames option: a Python-like half-open slice "A:B" of a file's frames.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace transient::tools {

// "A:B", "A:", ":B" or ":"; a negative index counts from the end, as in Python.
struct FrameSlice {
  std::optional<int64_t> start = std::nullopt;  // none: from the first frame
  std::optional<int64_t> stop = std::nullopt;   // none: to the last frame (exclusive end)

  std::string ToString() const;  // "2:-1", ":" ...
};

// The frames first, first + 1, ..., first + count - 1 of a file.
struct FrameRange {
  int64_t first = 0;
  int64_t count = 0;
  friend bool operator==(const FrameRange&, const FrameRange&) = default;
};

// Parses the text of --frames. InvalidArgument when it is not of the form above.
[[nodiscard]] absl::StatusOr<FrameSlice> ParseFrameSlice(absl::string_view text);

// Resolves `slice` against a file of `frame_count` frames. Unlike Python, which clamps, an
// index outside -frame_count..frame_count or an empty selection is an error (OutOfRange):
// asking for frames a file does not have is a mistake worth reporting.
[[nodiscard]] absl::StatusOr<FrameRange> ResolveFrameSlice(const FrameSlice& slice,
                                                           int64_t frame_count);

}  // namespace transient::tools
