// `transient bench`: its options are validated, and its table and JSON carry every row.
#include "tools/transient/commands/bench_command.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>

#include "tests/support/status_matchers.h"

namespace transient::tools {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::StatusIs;

TEST(BenchCommand, RefusesBadOptionsNamingThem) {
  BenchArgs args;
  args.min_seconds = 0.0;
  EXPECT_THAT(RunBench(args).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("--min-time = 0")));
  args = BenchArgs{};
  args.threads = {1, 0};
  EXPECT_THAT(RunBench(args).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("--threads = 0")));
  args.threads = {};
  EXPECT_THAT(args.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("at least one")));
}

TEST(BenchCommand, TableAndJsonCarryEveryRowWithItsRatio) {
  const std::vector<BenchRow> rows = {
      {.kernel = "density (256 phases)", .order = 3, .width = 163, .height = 120, .threads = 2,
       .unit = "evaluations/s", .reference = 5e7, .optimized = 2.5e9},
      {.kernel = "pipeline", .order = 4, .width = 640, .height = 480, .threads = 1,
       .unit = "frames/s", .reference = 0.5, .optimized = 2.0},
  };
  const std::string table = FormatBenchTable(rows);
  EXPECT_THAT(table, HasSubstr("density (256 phases)"));
  EXPECT_THAT(table, HasSubstr("50.0x"));
  EXPECT_THAT(table, HasSubstr("640x480"));
  EXPECT_THAT(table, HasSubstr("4.0x"));
  const std::string json = FormatBenchJson(rows);
  EXPECT_THAT(json, HasSubstr("\"ratio\": 50"));
  EXPECT_THAT(json, HasSubstr("\"unit\": \"frames/s\""));
  EXPECT_EQ(std::count(json.begin(), json.end(), '{'), 3);  // the document and two rows
}

TEST(BenchCommand, JsonWritesARowWithoutATimingAsNull) {
  // A kernel that did not run (0 units/s) has no ratio: null, not "nan" or "inf", which no JSON
  // reader accepts.
  const std::vector<BenchRow> rows = {{.kernel = "pipeline \"quoted\"", .order = 4, .width = 8,
                                       .height = 8, .threads = 1, .unit = "frames/s",
                                       .reference = 0.0, .optimized = 0.0}};
  const std::string json = FormatBenchJson(rows);
  EXPECT_THAT(json, HasSubstr("\"ratio\": null"));
  EXPECT_THAT(json, HasSubstr("\"kernel\": \"pipeline \\\"quoted\\\"\""));
  EXPECT_THAT(json, ::testing::Not(HasSubstr("nan")));
}

}  // namespace
}  // namespace transient::tools
