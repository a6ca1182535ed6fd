// The one parser of source URIs, "scheme:target?key=value&key=value", that every scheme's own
// parser starts from: the scheme, its target (a scene, a file, a device) and the keys in order.
#pragma once

#include <span>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "transient/drivers/source_registry.h"

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

// InvalidArgument "<uri>: <key> = '<value>'; expected <expected>", the message of a key whose
// value a scheme does not accept.
absl::Status BadKeyValue(absl::string_view uri, absl::string_view key, absl::string_view value,
                         absl::string_view expected);

// InvalidArgument "<scheme>: unknown key '<key>'; accepted keys: a, b, ...", the message of a key
// a scheme does not know, listing its keys.
absl::Status UnknownKey(absl::string_view scheme, absl::string_view key,
                        std::span<const SourceKey> keys);

// `text` with each %XX replaced by its byte (a key or value spelling a space as %20); a % not
// followed by two hex digits stays.
std::string PercentDecoded(absl::string_view text);

// "scheme:target?key=value&..." again, the keys in their order; ParseSourceUri's inverse.
std::string FormatSourceUri(const SourceUri& uri);

// `uri` with `key` set to `value`: replaced where given, else appended.
void SetSourceUriKey(SourceUri* uri, const std::string& key, const std::string& value);

}  // namespace transient::internal
