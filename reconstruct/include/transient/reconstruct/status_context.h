// The one way a status gains context on its way up: "context: message", the code unchanged
// (a file name, an option, a stream). Messages read from the outside in, as in
// "rec.h5: /moments: expected 3 dimensions, found 2".
#pragma once


#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"

namespace transient {

// `status` with "context: " before its message and the same code. OK stays OK, so that
// `return WithContext(path, Write(...));` reads naturally.
[[nodiscard]] inline absl::Status WithContext(absl::string_view context, const absl::Status& status) {
  if (status.ok()) return status;
  return absl::Status(status.code(), absl::StrCat(context, ": ", status.message()));
}

}  // namespace transient
