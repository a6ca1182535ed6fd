// `transient info`: what one of the project's files is, and what it holds.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "tools/transient/common/command_hooks.h"

namespace transient::tools {

// `transient info FILE`: what the file is (by its format attribute), its layout and a summary
// of its content, as lines of text. InvalidArgument for a file of no known format.
[[nodiscard]] absl::StatusOr<std::string> DescribeFile(const std::string& path);

}  // namespace transient::tools
