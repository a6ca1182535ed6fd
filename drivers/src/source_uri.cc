// Source URIs taken apart into scheme, target and keys.
#include "source_uri.h"

#include <algorithm>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"

namespace transient::internal {

absl::StatusOr<SourceUri> ParseSourceUri(absl::string_view uri) {
  const size_t colon = uri.find(':');
  if (colon == absl::string_view::npos || colon == 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("'", uri, "' is not a source URI; expected scheme:target?key=value&..."));
  }
  SourceUri parsed;
  parsed.scheme = std::string(uri.substr(0, colon));
  const absl::string_view rest = uri.substr(colon + 1);
  const size_t question = rest.find('?');
  parsed.target = std::string(rest.substr(0, question));
  if (question == absl::string_view::npos) return parsed;
  for (absl::string_view pair : absl::StrSplit(rest.substr(question + 1), '&', absl::SkipEmpty())) {
    const size_t equals = pair.find('=');
    if (equals == absl::string_view::npos || equals == 0 || equals + 1 == pair.size()) {
      return absl::InvalidArgumentError(absl::StrCat(parsed.scheme, ": malformed parameter '",
                                                     pair, "' in '", uri,
                                                     "'; expected key=value"));
    }
    std::string key(pair.substr(0, equals));
    if (std::any_of(parsed.keys.begin(), parsed.keys.end(),
                    [&](const auto& entry) { return entry.first == key; })) {
      return absl::InvalidArgumentError(
          absl::StrCat(parsed.scheme, ": key ", key, " given twice"));
    }
    parsed.keys.emplace_back(std::move(key), std::string(pair.substr(equals + 1)));
  }
  return parsed;
}

absl::Status BadKeyValue(absl::string_view uri, absl::string_view key, absl::string_view value,
                         absl::string_view expected) {
  return absl::InvalidArgumentError(
      absl::StrCat(uri, ": ", key, " = '", value, "'; expected ", expected));
}

absl::Status UnknownKey(absl::string_view scheme, absl::string_view key,
                        std::span<const SourceKey> keys) {
  std::string names;
  for (const SourceKey& k : keys) absl::StrAppend(&names, names.empty() ? "" : ", ", k.name);
  return absl::InvalidArgumentError(
      absl::StrCat(scheme, ": unknown key '", key, "'; accepted keys: ", names));
}

std::string PercentDecoded(absl::string_view text) {
  std::string out;
  for (size_t i = 0; i < text.size(); ++i) {
    int byte = 0;
    if (text[i] == '%' && i + 2 < text.size() &&
        absl::SimpleHexAtoi(text.substr(i + 1, 2), &byte)) {
      out.push_back(static_cast<char>(byte));
      i += 2;
    } else {
      out.push_back(text[i]);
    }
  }
  return out;
}

std::string FormatSourceUri(const SourceUri& uri) {
  std::string text = absl::StrCat(uri.scheme, ":", uri.target);
  for (size_t i = 0; i < uri.keys.size(); ++i) {
    absl::StrAppend(&text, i == 0 ? "?" : "&", uri.keys[i].first, "=", uri.keys[i].second);
  }
  return text;
}

void SetSourceUriKey(SourceUri* uri, const std::string& key, const std::string& value) {
  for (auto& [k, v] : uri->keys) {
    if (k == key) {
      v = value;
      return;
    }
  }
  uri->keys.emplace_back(key, value);
}

}  // namespace transient::internal
