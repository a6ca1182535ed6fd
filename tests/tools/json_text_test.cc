// The JSON spellings of the tools' summaries: strings escaped, non-finite numbers as null, so
// that summary.json, eval.json and bench --json parse with any JSON reader.
#include "tools/transient/common/json_text.h"

#include <gtest/gtest.h>

#include <limits>

namespace transient::tools {
namespace {

TEST(JsonText, StringsEscapeQuotesBackslashesAndControlCharacters) {
  EXPECT_EQ(JsonString("plain"), "\"plain\"");
  EXPECT_EQ(JsonString("a \"b\" \\ c"), "\"a \\\"b\\\" \\\\ c\"");
  EXPECT_EQ(JsonString("line\nnext\ttab\r"), "\"line\\nnext\\ttab\\r\"");
  EXPECT_EQ(JsonString(std::string("bell\x07", 5)), "\"bell\\u0007\"");
  EXPECT_EQ(JsonString(""), "\"\"");
}

TEST(JsonText, NumbersKeepTenDigitsAndNonFiniteIsNull) {
  EXPECT_EQ(JsonNumber(0.5), "0.5");
  EXPECT_EQ(JsonNumber(299792458.0), "299792458");
  EXPECT_EQ(JsonNumber(1.0 / 3.0), "0.3333333333");
  EXPECT_EQ(JsonNumber(std::numeric_limits<double>::quiet_NaN()), "null");
  EXPECT_EQ(JsonNumber(std::numeric_limits<double>::infinity()), "null");
  EXPECT_EQ(JsonNumber(-std::numeric_limits<double>::infinity()), "null");
}

TEST(JsonText, StringListsAreArrays) {
  EXPECT_EQ(JsonStrings({}), "[]");
  EXPECT_EQ(JsonStrings({"range.tiff", "slices/slice_000.png"}),
            "[\"range.tiff\", \"slices/slice_000.png\"]");
}

}  // namespace
}  // namespace transient::tools
