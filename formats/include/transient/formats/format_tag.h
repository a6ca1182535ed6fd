// The `format` attribute at the root of every transient HDF5 file: a name and a version,
// "transient-moments 1" or "transient-moments 1.2". Readers accept any minor version of the
// major versions they know and reject everything else (DESIGN.md, "Files").
#pragma once

#include <hdf5.h>

#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace transient {

struct FormatTag {
  std::string name;  // e.g. "transient-moments"
  int major = 0;
  int minor = 0;  // 0 when the tag gives only the major version
};

// "NAME MAJOR" or "NAME MAJOR.MINOR" with decimal versions; nullopt for anything else
// ("transient-moments", "transient-moments v1", " transient-moments 1").
std::optional<FormatTag> ParseFormatTag(absl::string_view text);

// Checks `text` (the attribute's value) against the format `name` with major version `major`.
// The message of an error says what was expected and what was found, e.g.
// "expected 'transient-moments 1', found 'transient-moments 2' (unsupported major version 2)".
absl::Status CheckFormatTag(absl::string_view text, absl::string_view name, int major);

// "transient-moments 1".
std::string FormatTagString(absl::string_view name, int major);

// Writes the attribute `format` = "<name> <major>" on `object` (a file's root group).
absl::Status WriteFormatAttribute(hid_t object, absl::string_view name, int major);

// Reads the attribute `format` of `object` and checks it with CheckFormatTag. `where` names
// the object for messages ("in.h5: /"): InvalidArgument "<where>: missing attribute format",
// "<where>: attribute format: expected a string, found float64" or "<where>: attribute
// format: expected 'transient-moments 1', found ...".
absl::Status ReadFormatAttribute(hid_t object, absl::string_view where, absl::string_view name,
                                 int major);

}  // namespace transient
