// The `format` attribute at the root of every transient HDF5 file: a name and a version,
// "transient-moments 1" or "transient-moments 1.2". Readers accept any minor version of the
// major versions they know and reject everything else (DESIGN.md, "Files").
#pragma once

#include <string>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace transient {

struct FormatTag {
  std::string name;  // e.g. "transient-moments"
  int major = 0;
  int minor = 0;  // 0 when the tag gives only the major version
};

// Checks `text` (the attribute's value) against the format `name` with major version `major`.
// The message of an error says what was expected and what was found, e.g.
// "expected 'transient-moments 1', found 'transient-moments 2' (unsupported major version 2)".
absl::Status CheckFormatTag(absl::string_view text, absl::string_view name, int major);

// "transient-moments 1".
std::string FormatTagString(absl::string_view name, int major);

}  // namespace transient
