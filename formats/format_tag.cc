// Parsing, checking, writing and reading of the root `format` attribute.
#include "transient/formats/format_tag.h"

#include <optional>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "transient/formats/h5.h"

namespace transient {

std::optional<FormatTag> ParseFormatTag(absl::string_view text) {
  const std::vector<absl::string_view> words = absl::StrSplit(text, ' ');
  if (words.size() != 2 || words[0].empty()) return std::nullopt;
  const std::vector<absl::string_view> numbers = absl::StrSplit(words[1], '.');
  if (numbers.size() > 2) return std::nullopt;
  FormatTag tag{.name = std::string(words[0])};
  for (absl::string_view number : numbers) {
    if (number.empty() || number.find_first_not_of("0123456789") != absl::string_view::npos) {
      return std::nullopt;
    }
  }
  if (!absl::SimpleAtoi(numbers[0], &tag.major)) return std::nullopt;
  if (numbers.size() == 2 && !absl::SimpleAtoi(numbers[1], &tag.minor)) return std::nullopt;
  return tag;
}

std::string FormatTagString(absl::string_view name, int major) {
  return absl::StrCat(name, " ", major);
}

absl::Status CheckFormatTag(absl::string_view text, absl::string_view name, int major) {
  const std::string expected_found =
      absl::StrCat("expected '", FormatTagString(name, major), "', found '", text, "'");
  const std::optional<FormatTag> tag = ParseFormatTag(text);
  if (!tag.has_value()) {
    return absl::InvalidArgumentError(
        absl::StrCat(expected_found, " (not of the form 'NAME MAJOR[.MINOR]')"));
  }
  if (tag->name != name) {
    return absl::InvalidArgumentError(absl::StrCat(expected_found, " (not a ", name, " file)"));
  }
  if (tag->major != major) {
    return absl::InvalidArgumentError(
        absl::StrCat(expected_found, " (unsupported major version ", tag->major, ")"));
  }
  return absl::OkStatus();
}

absl::Status WriteFormatAttribute(hid_t object, absl::string_view name, int major) {
  return h5::WriteStringAttribute(object, "format", FormatTagString(name, major));
}

absl::Status ReadFormatAttribute(hid_t object, absl::string_view where, absl::string_view name,
                                 int major) {
  absl::StatusOr<std::string> text = h5::ReadStringAttribute(object, "format", where);
  if (!text.ok()) return text.status();
  if (absl::Status tag = CheckFormatTag(*text, name, major); !tag.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": attribute format: ", tag.message()));
  }
  return absl::OkStatus();
}

}  // namespace transient
