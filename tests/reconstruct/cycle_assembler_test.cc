#include "transient/reconstruct/cycle_assembler.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "tests/support/status_matchers.h"
#include "transient/reconstruct/demodulation.h"

namespace transient {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

constexpr ImageGeometry kAssemblerGeometry{5, 4};

AcquisitionSchedule MakeSchedule(int takes = 1) {
  ScheduleOptions options;
  options.order = 2;
  options.zeroth = ZerothScheme::kUnmodulatedPair;
  options.takes = takes;
  absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(options);
  EXPECT_THAT(schedule.status(), IsOk());
  return *std::move(schedule);
}

// The frames of `cycle` as a source numbers them; pixel values encode the sequence number.
std::vector<RawFrame> Frames(const AcquisitionSchedule& schedule, int64_t cycle) {
  std::vector<RawFrame> frames;
  const int n = schedule.raw_frames_per_frame();
  for (int i = 0; i < n; ++i) {
    RawFrame f;
    f.config = schedule.exposures()[i];
    f.config.cycle = cycle;
    f.config.sequence = static_cast<uint64_t>(cycle * n + i);
    f.geometry = kAssemblerGeometry;
    f.pixels.assign(static_cast<size_t>(kAssemblerGeometry.pixel_count()),
                    static_cast<float>(f.config.sequence));
    frames.push_back(f);
  }
  return frames;
}

CycleAssembler MakeAssembler(const AcquisitionSchedule& schedule) {
  absl::StatusOr<CycleAssembler> assembler = CycleAssembler::Create(schedule, kAssemblerGeometry);
  EXPECT_THAT(assembler.status(), IsOk());
  return *std::move(assembler);
}

// Adds all frames; returns how many Add calls reported a complete cycle.
int AddAll(CycleAssembler& assembler, const std::vector<RawFrame>& frames) {
  int complete = 0;
  for (const RawFrame& f : frames) {
    absl::StatusOr<bool> done = assembler.Add(f);
    EXPECT_THAT(done.status(), IsOk());
    complete += done.ok() && *done;
  }
  return complete;
}

TEST(CycleAssembler, CompletesEachCycleAtItsLastFrameInScheduleOrder) {
  const AcquisitionSchedule schedule = MakeSchedule(2);
  CycleAssembler assembler = MakeAssembler(schedule);
  std::mt19937_64 rng(41);
  for (int64_t cycle = 0; cycle < 3; ++cycle) {
    std::vector<RawFrame> frames = Frames(schedule, cycle);
    std::shuffle(frames.begin(), frames.end(), rng);
    for (size_t i = 0; i + 1 < frames.size(); ++i) {
      absl::StatusOr<bool> done = assembler.Add(frames[i]);
      ASSERT_THAT(done.status(), IsOk());
      EXPECT_FALSE(*done);
    }
    EXPECT_TRUE(assembler.TakeCycle().empty());  // not complete yet
    absl::StatusOr<bool> done = assembler.Add(frames.back());
    ASSERT_THAT(done.status(), IsOk());
    EXPECT_TRUE(*done);
    const std::vector<RawFrame> complete = assembler.TakeCycle();
    ASSERT_EQ(complete.size(), static_cast<size_t>(schedule.raw_frames_per_frame()));
    for (size_t i = 0; i < complete.size(); ++i) {
      EXPECT_EQ(*schedule.IndexOf(complete[i].config), static_cast<int>(i));
      EXPECT_EQ(complete[i].config.cycle, cycle);
    }
  }
  EXPECT_EQ(assembler.dropped_frames(), 0);
  EXPECT_EQ(assembler.dropped_cycles(), 0);
}

TEST(CycleAssembler, RecoversAfterAMissingFrame) {
  const AcquisitionSchedule schedule = MakeSchedule();
  CycleAssembler assembler = MakeAssembler(schedule);
  std::vector<RawFrame> first = Frames(schedule, 0);
  const RawFrame lost = first[5];
  first.erase(first.begin() + 5);
  EXPECT_EQ(AddAll(assembler, first), 0);

  const std::vector<RawFrame> second = Frames(schedule, 1);
  EXPECT_THAT(assembler.Add(second[0]).status(),
              StatusIs(absl::StatusCode::kDataLoss,
                       HasSubstr("cycle 0 lacks 1 of 10 exposures; dropped it. Missing: " +
                                 DescribeExposure(schedule.exposures()[5]))));
  EXPECT_EQ(assembler.dropped_cycles(), 1);
  EXPECT_EQ(assembler.dropped_frames(), 9);
  EXPECT_EQ(assembler.current_cycle(), 1);
  EXPECT_EQ(AddAll(assembler, std::vector<RawFrame>(second.begin() + 1, second.end())), 1);
  const std::vector<RawFrame> cycle = assembler.TakeCycle();
  ASSERT_EQ(cycle.size(), 10u);
  EXPECT_EQ(cycle[0].config.sequence, second[0].config.sequence);

  // The frame that was lost turns up late: refused, counted.
  EXPECT_THAT(assembler.Add(lost).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("is late")));
  EXPECT_EQ(assembler.dropped_frames(), 10);

  // And the assembled cycle demodulates.
  absl::StatusOr<Demodulator> demodulator = Demodulator::Create(schedule, kAssemblerGeometry, {});
  ASSERT_THAT(demodulator.status(), IsOk());
  MomentImage out;
  EXPECT_THAT(demodulator->Demodulate(cycle, &out), IsOk());
}

TEST(CycleAssembler, DuplicateAndForeignFramesAreDroppedAndTheCycleGoesOn) {
  const AcquisitionSchedule schedule = MakeSchedule();
  CycleAssembler assembler = MakeAssembler(schedule);
  const std::vector<RawFrame> frames = Frames(schedule, 3);
  ASSERT_THAT(assembler.Add(frames[0]).status(), IsOk());
  ASSERT_THAT(assembler.Add(frames[1]).status(), IsOk());

  RawFrame duplicate = frames[1];
  duplicate.config.sequence = 777;
  EXPECT_THAT(assembler.Add(duplicate).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("frame 777 (cycle 3, " + DescribeExposure(frames[1].config) +
                                 ") duplicates frame 31")));
  RawFrame foreign = frames[2];
  foreign.config.exposure_s *= 2.0;
  EXPECT_THAT(assembler.Add(foreign).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("not an exposure")));
  RawFrame short_frame = frames[2];
  short_frame.pixels.pop_back();
  EXPECT_THAT(assembler.Add(short_frame).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("holds 19 pixels")));
  RawFrame other_geometry = frames[2];
  other_geometry.geometry = {4, 5};
  EXPECT_THAT(assembler.Add(other_geometry).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("has geometry 4x5")));
  EXPECT_EQ(assembler.dropped_frames(), 4);
  EXPECT_EQ(assembler.frames_pending(), 2);

  EXPECT_EQ(AddAll(assembler, std::vector<RawFrame>(frames.begin() + 2, frames.end())), 1);
  EXPECT_EQ(assembler.TakeCycle().size(), 10u);
  EXPECT_EQ(assembler.dropped_cycles(), 0);
}

TEST(CycleAssembler, AddingBeforeTakingACompleteCycleIsRefused) {
  const AcquisitionSchedule schedule = MakeSchedule();
  CycleAssembler assembler = MakeAssembler(schedule);
  EXPECT_EQ(AddAll(assembler, Frames(schedule, 0)), 1);
  EXPECT_TRUE(assembler.cycle_ready());
  EXPECT_THAT(assembler.Add(Frames(schedule, 1)[0]).status(),
              StatusIs(absl::StatusCode::kFailedPrecondition, HasSubstr("call TakeCycle()")));
  EXPECT_EQ(assembler.dropped_frames(), 1);
  EXPECT_EQ(assembler.TakeCycle().size(), 10u);
  EXPECT_FALSE(assembler.cycle_ready());
}

TEST(CycleAssembler, ResetDropsThePartialCycle) {
  const AcquisitionSchedule schedule = MakeSchedule();
  CycleAssembler assembler = MakeAssembler(schedule);
  const std::vector<RawFrame> frames = Frames(schedule, 0);
  ASSERT_THAT(assembler.Add(frames[0]).status(), IsOk());
  assembler.Reset();
  EXPECT_EQ(assembler.dropped_cycles(), 1);
  EXPECT_EQ(assembler.dropped_frames(), 1);
  EXPECT_FALSE(assembler.current_cycle().has_value());
  EXPECT_EQ(AddAll(assembler, frames), 1);
}

TEST(CycleAssembler, RefusesAnEmptyGeometry) {
  EXPECT_THAT(CycleAssembler::Create(MakeSchedule(), {0, 3}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("geometry 0x3")));
}

}  // namespace
}  // namespace transient
