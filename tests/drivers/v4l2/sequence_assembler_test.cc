// The alignment of V4L2 buffers into phase sequences, on streams written as a driver delivers
// them (struct v4l2_buffer's sequence counts dropped frames too; ERROR-flagged buffers;
// bytesused; CLOCK_MONOTONIC timestamps; ../shared/research/v4l2.md §2.4, §5.4): every rule,
// every fault with the counter it produces, and on random faulty streams that no emitted
// sequence holds a wrong, missing or broken buffer.
#include "v4l2/sequence_assembler.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <vector>

#include "tests/support/status_matchers.h"

namespace transient::v4l2 {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

constexpr size_t kBytes = 1000;
constexpr int64_t kFrameNs = 1'000'000;  // 1 ms between the buffers of a sequence
constexpr int64_t kPauseNs = 20'000'000;  // the sensor's idle time between sequences

DequeuedBuffer Buffer(uint32_t sequence, int64_t timestamp_ns) {
  return {.sequence = sequence, .timestamp_ns = timestamp_ns, .bytes_used = kBytes};
}

AssemblerOptions Options(Alignment alignment, int phases = 4, int64_t gap_ns = 5'000'000) {
  return {.phases = phases, .alignment = alignment, .expected_bytes = kBytes, .gap_ns = gap_ns};
}

// The phases the assembler gave, -1 for a discarded buffer, and where sequences completed.
struct Fates {
  std::vector<int> phases;
  std::vector<bool> completes;
};

Fates AddAll(SequenceAssembler& assembler, const std::vector<DequeuedBuffer>& buffers) {
  Fates fates;
  for (const DequeuedBuffer& b : buffers) {
    const Placement p = assembler.Add(b);
    fates.phases.push_back(p.phase.value_or(-1));
    fates.completes.push_back(p.completes);
  }
  return fates;
}

int64_t Dropped(const SequenceAssembler& assembler, DropReason reason) {
  return assembler.counters().dropped[static_cast<int>(reason)];
}

// Buffers with driver sequence numbers `first`..`first + count - 1`, evenly spaced.
std::vector<DequeuedBuffer> Evenly(uint32_t first, int count, int64_t start_ns = 0) {
  std::vector<DequeuedBuffer> buffers;
  for (int i = 0; i < count; ++i) buffers.push_back(Buffer(first + i, start_ns + i * kFrameNs));
  return buffers;
}

TEST(SequenceAssembler, CountedAlignmentEmitsEveryWholeSequence) {
  SequenceAssembler assembler(Options(Alignment::kSequence, 4, 0));
  const Fates fates = AddAll(assembler, Evenly(100, 12));
  EXPECT_EQ(fates.phases, (std::vector<int>{0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3}));
  EXPECT_EQ(fates.completes, (std::vector<bool>{false, false, false, true, false, false, false,
                                                true, false, false, false, true}));
  EXPECT_EQ(assembler.counters().sequences, 3);
  EXPECT_EQ(assembler.counters().dropped_total(), 0);
  EXPECT_EQ(assembler.counters().discarded_buffers, 0);
  EXPECT_EQ(assembler.counters().buffers, 12);
}

TEST(SequenceAssembler, LostFrameDropsItsSequenceAndTheCountFindsTheNextPhaseZero) {
  SequenceAssembler assembler(Options(Alignment::kSequence, 4, 0));
  std::vector<DequeuedBuffer> stream = Evenly(0, 12);
  stream.erase(stream.begin() + 6);  // driver sequence 6 lost for want of a queued buffer
  const Fates fates = AddAll(assembler, stream);
  // 4, 5 were placed; 7 is phase 3 of the broken sequence; 8 starts the next.
  EXPECT_EQ(fates.phases, (std::vector<int>{0, 1, 2, 3, 0, 1, -1, 0, 1, 2, 3}));
  EXPECT_EQ(assembler.counters().sequences, 2);
  EXPECT_EQ(Dropped(assembler, DropReason::kSequenceGap), 1);
  EXPECT_EQ(assembler.counters().driver_frames_lost, 1);
  EXPECT_EQ(assembler.counters().discarded_buffers, 3);
}

TEST(SequenceAssembler, LosingASequencesWorthOfFramesIsStillAGap) {
  // Two phases; driver sequences 1 and 2 lost: 3 is phase 1 by the count, but not of 0's
  // sequence.
  SequenceAssembler assembler(Options(Alignment::kSequence, 2, 0));
  std::vector<DequeuedBuffer> stream = Evenly(0, 6);
  stream.erase(stream.begin() + 1, stream.begin() + 3);
  const Fates fates = AddAll(assembler, stream);
  EXPECT_EQ(fates.phases, (std::vector<int>{0, -1, 0, 1}));
  EXPECT_EQ(assembler.counters().sequences, 1);
  EXPECT_EQ(Dropped(assembler, DropReason::kSequenceGap), 1);
  EXPECT_EQ(assembler.counters().driver_frames_lost, 2);
}

TEST(SequenceAssembler, ErrorFlagOrWrongSizeDropsTheWholeSequence) {
  for (DropReason reason : {DropReason::kErrorFlag, DropReason::kWrongSize}) {
    SequenceAssembler assembler(Options(Alignment::kSequence, 4, 0));
    std::vector<DequeuedBuffer> stream = Evenly(0, 12);
    if (reason == DropReason::kErrorFlag) {
      stream[5].error_flag = true;
    } else {
      stream[5].bytes_used = kBytes / 2;
    }
    const Fates fates = AddAll(assembler, stream);
    EXPECT_EQ(fates.phases, (std::vector<int>{0, 1, 2, 3, 0, -1, -1, -1, 0, 1, 2, 3}))
        << DropReasonName(reason);
    EXPECT_EQ(assembler.counters().sequences, 2);
    EXPECT_EQ(Dropped(assembler, reason), 1);
    EXPECT_EQ(assembler.counters().dropped_total(), 1);
    EXPECT_EQ(assembler.counters().discarded_buffers, 4);
  }
}

TEST(SequenceAssembler, PauseWhereTheCountSaysMidSequenceResyncsOnIt) {
  // The sensor pauses between sequences of 4, but one buffer of the second sequence was never
  // counted by the driver (discarded by the receiver): the count drifts, the pause corrects it.
  SequenceAssembler assembler(Options(Alignment::kSequence, 4, 5'000'000));
  std::vector<DequeuedBuffer> stream = Evenly(0, 4);
  for (const DequeuedBuffer& b : Evenly(4, 3, 3 * kFrameNs + kPauseNs)) stream.push_back(b);
  for (const DequeuedBuffer& b : Evenly(7, 4, 5 * kFrameNs + 2 * kPauseNs)) stream.push_back(b);
  const Fates fates = AddAll(assembler, stream);
  // The second sequence has phases 0..2 and no 3; the third starts after a pause at driver
  // sequence 7, which the count calls phase 3: it becomes phase 0.
  EXPECT_EQ(fates.phases, (std::vector<int>{0, 1, 2, 3, 0, 1, 2, 0, 1, 2, 3}));
  EXPECT_EQ(assembler.counters().sequences, 2);
  EXPECT_EQ(Dropped(assembler, DropReason::kTimestampGap), 1);
}

TEST(SequenceAssembler, DriverCountThatRestartsIsFollowed) {
  SequenceAssembler assembler(Options(Alignment::kSequence, 4, 0));
  std::vector<DequeuedBuffer> stream = Evenly(50, 6);  // 50..53 whole, 54, 55 open
  for (const DequeuedBuffer& b : Evenly(0, 4, 10 * kFrameNs)) stream.push_back(b);
  const Fates fates = AddAll(assembler, stream);
  EXPECT_EQ(fates.phases, (std::vector<int>{0, 1, 2, 3, 0, 1, 0, 1, 2, 3}));
  EXPECT_EQ(assembler.counters().sequences, 2);
  EXPECT_EQ(Dropped(assembler, DropReason::kSequenceGap), 1);
  EXPECT_EQ(assembler.counters().driver_frames_lost, 0);
}

TEST(SequenceAssembler, SequenceNumbersWrapAroundTwoToThe32) {
  SequenceAssembler assembler(Options(Alignment::kSequence, 4, 0));
  const Fates fates = AddAll(assembler, Evenly(0xfffffffeu, 8));
  EXPECT_EQ(fates.phases, (std::vector<int>{0, 1, 2, 3, 0, 1, 2, 3}));
  EXPECT_EQ(assembler.counters().sequences, 2);
  EXPECT_EQ(assembler.counters().driver_frames_lost, 0);
}

TEST(SequenceAssembler, PauseAlignmentWaitsForTheFirstPause) {
  SequenceAssembler assembler(Options(Alignment::kGap, 4));
  // The stream starts mid-sequence (two buffers), then two whole sequences with pauses.
  std::vector<DequeuedBuffer> stream = Evenly(0, 2);
  for (const DequeuedBuffer& b : Evenly(2, 4, kFrameNs + kPauseNs)) stream.push_back(b);
  for (const DequeuedBuffer& b : Evenly(6, 4, 4 * kFrameNs + 2 * kPauseNs)) stream.push_back(b);
  const Fates fates = AddAll(assembler, stream);
  EXPECT_EQ(fates.phases, (std::vector<int>{-1, -1, 0, 1, 2, 3, 0, 1, 2, 3}));
  EXPECT_EQ(assembler.counters().sequences, 2);
  EXPECT_EQ(assembler.counters().dropped_total(), 0);
  EXPECT_EQ(assembler.counters().discarded_buffers, 2);
}

// A driver's timestamps may jump from one end of int64 to the other (found by fuzzing,
// tests/fuzz/v4l2_fuzz.cc: the difference overflowed). A jump forward is a pause, one backward
// none, and nothing overflows (UBSan would fail the test).
TEST(SequenceAssembler, TimestampsAtTheEndsOfInt64AreAPauseForwardAndNoneBackward) {
  SequenceAssembler assembler(Options(Alignment::kGap, 2));
  const Fates fates =
      AddAll(assembler, {Buffer(0, INT64_MIN), Buffer(1, INT64_MAX), Buffer(2, INT64_MAX),
                         Buffer(3, INT64_MIN), Buffer(4, INT64_MIN + kFrameNs)});
  // The jump forward starts a sequence (0, 1); the jump back is no pause, so the buffer after
  // the whole sequence cannot start one.
  EXPECT_EQ(fates.phases, (std::vector<int>{-1, 0, 1, -1, -1}));
  EXPECT_EQ(assembler.counters().sequences, 1);
}

TEST(SequenceAssembler, PauseAlignmentDropsShortOverlongAndBrokenSequences) {
  SequenceAssembler assembler(Options(Alignment::kGap, 4));
  std::vector<DequeuedBuffer> stream = {Buffer(0, 0)};  // the tail of a sequence before ours
  int64_t t = kFrameNs;
  uint32_t seq = 1;
  const auto sequence_of = [&](int count, bool skip_one) {
    t += kPauseNs;
    for (int i = 0; i < count; ++i) {
      if (skip_one && i == 2) ++seq;  // a frame the driver lost
      stream.push_back(Buffer(seq++, t));
      t += kFrameNs;
    }
  };
  sequence_of(4, false);  // whole
  sequence_of(3, false);  // too short: dropped at the next pause
  sequence_of(6, false);  // four placed and emitted, then overlong: counted once
  sequence_of(4, true);   // a lost frame inside
  sequence_of(4, false);  // whole
  const Fates fates = AddAll(assembler, stream);
  EXPECT_EQ(fates.phases, (std::vector<int>{-1, 0, 1, 2, 3, 0, 1, 2, 0, 1, 2, 3, -1, -1, 0, 1, -1,
                                            -1, 0, 1, 2, 3}));
  EXPECT_EQ(assembler.counters().sequences, 3);
  EXPECT_EQ(Dropped(assembler, DropReason::kTimestampGap), 1);
  EXPECT_EQ(Dropped(assembler, DropReason::kOverlong), 1);
  EXPECT_EQ(Dropped(assembler, DropReason::kSequenceGap), 1);
  EXPECT_EQ(assembler.counters().driver_frames_lost, 1);
}

TEST(SequenceAssembler, TriggeredSequencesTakeTheFramesTheirNumbersGive) {
  SequenceAssembler assembler(Options(Alignment::kTrigger, 3));
  uint32_t seq = 0;
  int64_t t = 0;
  const auto next = [&] {
    t += kFrameNs;
    return assembler.Add(Buffer(seq++, t));
  };
  EXPECT_TRUE(assembler.TriggerDone());
  EXPECT_FALSE(next().phase.has_value());  // before any trigger: not ours
  assembler.BeginSequence(1);
  EXPECT_FALSE(assembler.TriggerDone());
  EXPECT_EQ(next().phase, 0);
  EXPECT_EQ(next().phase, 1);
  const Placement last = next();
  EXPECT_EQ(last.phase, 2);
  EXPECT_TRUE(last.completes);
  EXPECT_TRUE(assembler.TriggerDone());
  EXPECT_FALSE(next().phase.has_value());  // a fourth buffer after a sequence of three
  assembler.BeginSequence(5);
  EXPECT_EQ(next().phase, 0);
  EXPECT_EQ(assembler.trigger_frames_seen(), 1);
  assembler.Abandon();  // a dequeue timeout
  EXPECT_TRUE(assembler.TriggerDone());
  EXPECT_FALSE(next().phase.has_value());
  // The next trigger (frames 8..10) while a late frame of the abandoned one (7) comes.
  assembler.BeginSequence(8);
  EXPECT_FALSE(next().phase.has_value()) << "frame 7: late, of the abandoned trigger";
  EXPECT_EQ(assembler.trigger_frames_seen(), 0);
  EXPECT_EQ(next().phase, 0);
  ++seq;  // frame 9 lost: its number shows at frame 10
  EXPECT_FALSE(next().phase.has_value());
  EXPECT_TRUE(assembler.TriggerDone());
  // A trigger whose first frame is lost: frame 12 is its phase 1, and the sequence is gone.
  assembler.BeginSequence(11);
  ++seq;
  EXPECT_FALSE(next().phase.has_value());
  EXPECT_FALSE(next().phase.has_value());
  EXPECT_TRUE(assembler.TriggerDone());
  assembler.BeginSequence(14);
  EXPECT_EQ(next().phase, 0);
  assembler.BeginSequence(17);  // a trigger before the last one's frames came
  EXPECT_EQ(assembler.counters().sequences, 1);
  EXPECT_EQ(Dropped(assembler, DropReason::kAbandoned), 2);
  EXPECT_EQ(Dropped(assembler, DropReason::kSequenceGap), 2);
  EXPECT_EQ(assembler.counters().driver_frames_lost, 2);
}

TEST(SequenceAssembler, ResetAbandonsTheOpenSequenceAndCountsAfresh) {
  SequenceAssembler assembler(Options(Alignment::kSequence, 4, 0));
  AddAll(assembler, Evenly(0, 6));
  assembler.Reset();  // STREAMOFF, STREAMON: the driver counts from 0 again
  const Fates fates = AddAll(assembler, Evenly(0, 4, 100 * kFrameNs));
  EXPECT_EQ(fates.phases, (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(assembler.counters().sequences, 2);
  EXPECT_EQ(Dropped(assembler, DropReason::kAbandoned), 1);
  EXPECT_EQ(assembler.counters().driver_frames_lost, 0);
}

// A sensor streaming sequences of N phases (its truth: phase = frame mod N, the driver's
// sequence = frame) through a faulty path: lost frames, flagged and short buffers, uncounted
// discards with a pause. Whatever comes, every emitted sequence must be N buffers in order,
// each the phase it really is, consecutive, unflagged and whole.
TEST(SequenceAssembler, RandomFaultsNeverEmitAWrongOrBrokenSequence) {
  for (Alignment alignment : {Alignment::kSequence, Alignment::kGap}) {
    for (uint32_t seed = 1; seed <= 20; ++seed) {
      std::mt19937 rng(seed);
      const int phases = 1 + static_cast<int>(rng() % 6);
      SequenceAssembler assembler(Options(alignment, phases, 5'000'000));
      struct Truth {
        DequeuedBuffer buffer;
        int phase;
      };
      std::vector<Truth> window;  // the buffers of the open sequence, as placed
      int64_t t = 0;
      int64_t emitted = 0;
      for (uint32_t frame = 0; frame < 600; ++frame) {
        const int phase = static_cast<int>(frame % phases);
        t += phase == 0 ? kPauseNs : kFrameNs;
        // The first buffer after STREAMON is phase 0 (what kSequence assumes) and arrives.
        const uint32_t r = frame == 0 ? 50 : rng() % 100;
        if (r < 4) continue;  // lost: the driver's count skips it
        DequeuedBuffer buffer = Buffer(frame, t);
        buffer.error_flag = r >= 4 && r < 7;
        if (r >= 7 && r < 10) buffer.bytes_used = kBytes - 1 - rng() % 10;
        const Placement p = assembler.Add(buffer);
        if (!p.phase.has_value()) continue;
        ASSERT_EQ(*p.phase, phase) << "seed " << seed << " frame " << frame;
        if (*p.phase == 0) window.clear();
        window.push_back({buffer, phase});
        if (!p.completes) continue;
        ++emitted;
        ASSERT_EQ(static_cast<int>(window.size()), phases) << "seed " << seed;
        for (int k = 0; k < phases; ++k) {
          EXPECT_EQ(window[k].phase, k);
          EXPECT_FALSE(window[k].buffer.error_flag);
          EXPECT_EQ(window[k].buffer.bytes_used, kBytes);
          if (k > 0) {
            EXPECT_EQ(window[k].buffer.sequence, window[k - 1].buffer.sequence + 1)
                << AlignmentName(alignment) << " seed " << seed << " phases " << phases;
          }
        }
      }
      const AssemblerCounters& c = assembler.counters();
      EXPECT_EQ(c.sequences, emitted);
      EXPECT_GT(emitted, 0) << "seed " << seed << ": a mostly clean stream emits something";
      EXPECT_GT(c.dropped_total(), 0) << "seed " << seed;
      // Every buffer went to an emitted sequence, was discarded, or waits in the open one.
      EXPECT_LE(c.sequences * phases + c.discarded_buffers, c.buffers);
      EXPECT_GT(c.sequences * phases + c.discarded_buffers, c.buffers - phases);
    }
  }
}

TEST(SequenceAssembler, BadOptionsAreRefusedNamingTheField) {
  EXPECT_THAT(Options(Alignment::kSequence).Validate(), IsOk());
  EXPECT_THAT(Options(Alignment::kSequence, 0).Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("phases per sequence 0")));
  EXPECT_THAT(Options(Alignment::kSequence, 65).Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("outside 1..64")));
  EXPECT_THAT(Options(Alignment::kSequence, 4, -1).Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("at least 0")));
  EXPECT_THAT(Options(Alignment::kSequence, 4, 0).Validate(), IsOk());
  EXPECT_THAT(Options(Alignment::kGap, 4, 0).Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("positive for align=gap")));
  AssemblerOptions no_size = Options(Alignment::kTrigger);
  no_size.expected_bytes = 0;
  EXPECT_THAT(no_size.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("buffer size is 0")));
  Alignment alignment = Alignment::kTrigger;
  EXPECT_THAT(ParseAlignment("gap", &alignment), IsOk());
  EXPECT_EQ(alignment, Alignment::kGap);
  EXPECT_THAT(ParseAlignment("phase", &alignment),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("align=phase is not one of trigger, sequence, gap")));
  EXPECT_EQ(alignment, Alignment::kGap);
}

}  // namespace
}  // namespace transient::v4l2
