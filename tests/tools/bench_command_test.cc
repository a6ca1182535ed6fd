// `transient bench`: its options are validated, its table and JSON carry every row, and the
// machine's probes measure what they say.
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
  const BenchReport report = {
      .rows = {{.kernel = "density (256 phases)",
                .order = 3,
                .width = 163,
                .height = 120,
                .threads = 2,
                .unit = "evaluations/s",
                .reference = 5e7,
                .optimized = 2.5e9},
               {.kernel = "pipeline",
                .order = 4,
                .width = 640,
                .height = 480,
                .threads = 1,
                .unit = "frames/s",
                .reference = 0.5,
                .optimized = 2.0}},
      .machine = {{.probe = "stores to a 64 MiB buffer",
                   .when = "start",
                   .threads = 2,
                   .unit = "bytes/s",
                   .one_thread = 8e9,
                   .these_threads = 1.2e10}},
  };
  const std::string table = FormatBenchTable(report);
  EXPECT_THAT(table, HasSubstr("density (256 phases)"));
  EXPECT_THAT(table, HasSubstr("50.0x"));
  EXPECT_THAT(table, HasSubstr("640x480"));
  EXPECT_THAT(table, HasSubstr("4.0x"));
  EXPECT_THAT(table, HasSubstr("stores to a 64 MiB buffer"));
  EXPECT_THAT(table, HasSubstr("1.50x"));
  const std::string json = FormatBenchJson(report);
  EXPECT_THAT(json, HasSubstr("\"ratio\": 50"));
  EXPECT_THAT(json, HasSubstr("\"unit\": \"frames/s\""));
  EXPECT_THAT(json, HasSubstr("\"probe\": \"stores to a 64 MiB buffer\""));
  EXPECT_THAT(json, HasSubstr("\"ratio\": 1.5"));
  // The document, two rows and a machine row.
  EXPECT_EQ(std::count(json.begin(), json.end(), '{'), 4);
}

TEST(BenchCommand, JsonWritesARowWithoutATimingAsNull) {
  // A kernel that did not run (0 units/s) has no ratio: null, not "nan" or "inf", which no JSON
  // reader accepts.
  const BenchReport report = {.rows = {{.kernel = "pipeline \"quoted\"",
                                        .order = 4,
                                        .width = 8,
                                        .height = 8,
                                        .threads = 1,
                                        .unit = "frames/s",
                                        .reference = 0.0,
                                        .optimized = 0.0}},
                              .machine = {}};
  const std::string json = FormatBenchJson(report);
  EXPECT_THAT(json, HasSubstr("\"ratio\": null"));
  EXPECT_THAT(json, HasSubstr("\"kernel\": \"pipeline \\\"quoted\\\"\""));
  EXPECT_THAT(json, ::testing::Not(HasSubstr("nan")));
}

TEST(BenchCommand, TheMachineIsMeasuredOnOneThreadAndOnMore) {
  // Nothing to compare on one thread. (Less work than `transient bench`'s, for the tests' time.)
  const MachineWork work{.chain_steps = 1 << 16, .buffer_floats = 1 << 20, .passes = 2};
  EXPECT_TRUE(MeasureMachine("start", 1, 0.01, work).empty());
  const std::vector<MachineRow> rows = MeasureMachine("end", 2, 0.01, work);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].probe, "multiply-adds in registers");
  EXPECT_EQ(rows[1].probe, "stores to a 4 MiB buffer");
  for (const MachineRow& row : rows) {
    EXPECT_EQ(row.when, "end");
    EXPECT_EQ(row.threads, 2);
    // Rates of a real loop: a multiply-add or a byte takes more than 1e-12 s and less than 1 s
    // (not a timing target, only that what was timed is the work counted).
    EXPECT_GT(row.one_thread, 1.0) << row.probe;
    EXPECT_LT(row.one_thread, 1e12) << row.probe;
    EXPECT_GT(row.these_threads, 1.0) << row.probe;
    EXPECT_LT(row.these_threads, 2e12) << row.probe;
    // Two threads cannot do more than twice one's work (3, for timing noise on a small work);
    // counting each thread's work twice over, or the whole buffer once per thread, gives ~4.
    EXPECT_LT(row.ratio(), 3.0) << row.probe;
  }
}

}  // namespace
}  // namespace transient::tools
