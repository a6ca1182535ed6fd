// The one parser of source URIs, "scheme:target?key=value&key=value", that every scheme's own
// parser starts from: the scheme, its target (a scene, a file, a device) and the keys in order.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace transient::internal {

struct SourceUri {
  std::string scheme;  // before the first ':'
  std::string target;  // between ':' and '?', may be empty
  std::vector<std::pair<std::string, std::string>> keys;  // in the order given, each once
};

// Splits `uri`. InvalidArgument, prefixed "<scheme>: ", for no scheme, a parameter that is not
// key=value with both sides non-empty ("malformed parameter 'm' in '<uri>'; expected
// key=value"), or a key given twice ("key m given twice").
absl::StatusOr<SourceUri> ParseSourceUri(absl::string_view uri);

// "scheme:target?key=value&..." again, the keys in their order; ParseSourceUri's inverse.
std::string FormatSourceUri(const SourceUri& uri);

// `uri` with `key` set to `value`: replaced where given, else appended.
void SetSourceUriKey(SourceUri* uri, const std::string& key, const std::string& value);

}  // namespace transient::internal
