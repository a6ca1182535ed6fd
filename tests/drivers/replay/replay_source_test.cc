// The replay source: recorded frames in order, the end of a recording, loops, seeking, pacing,
// unreadable frames and bad URIs.
#include "transient/drivers/replay_source.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>

#include "tests/formats/test_captures.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"

namespace transient {
namespace {

using ::testing::HasSubstr;
using testing::TestCamera;
using testing::TestFrame;
using testing::TestOptions;
using testing::TestSchedule;
using testing::WriteTestCapture;
using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;

constexpr int64_t kFrames = 30;  // 3 cycles of TestSchedule's 10 raw frames
constexpr absl::Duration kTimeout = absl::Seconds(5);

class Replay : public ::testing::Test {
 protected:
  void SetUp() override { WriteTestCapture(path_, kFrames, TestOptions()); }

  std::unique_ptr<ReplaySource> OpenStarted(const std::string& query) {
    absl::StatusOr<std::unique_ptr<ReplaySource>> source =
        ReplaySource::Open(absl::StrCat("replay:", path_, query));
    EXPECT_THAT(source.status(), IsOk());
    if (!source.ok()) return nullptr;
    EXPECT_THAT((*source)->Start(), IsOk());
    return *std::move(source);
  }

  ScratchDirectory scratch_;
  std::string path_ = scratch_.File("capture.h5");
};

TEST_F(Replay, DeliversEveryFrameInOrderThenOutOfRange) {
  absl::StatusOr<std::unique_ptr<CaptureSource>> opened =
      OpenSource(absl::StrCat("replay:", path_, "?pace=fast"));
  ASSERT_THAT(opened.status(), IsOk());
  CaptureSource& source = **opened;
  EXPECT_TRUE(source.capabilities().replay);
  EXPECT_EQ(source.camera().geometry, TestCamera().geometry);
  EXPECT_EQ(source.schedule().raw_frames_per_frame(), 10);
  RawFrame frame;
  EXPECT_THAT(source.Next(kTimeout, &frame), StatusIs(absl::StatusCode::kFailedPrecondition,
                                                      HasSubstr("not started")));
  ASSERT_THAT(source.Start(), IsOk());
  for (int64_t i = 0; i < kFrames; ++i) {
    ASSERT_THAT(source.Next(kTimeout, &frame), IsOk());
    const RawFrame want = TestFrame(TestCamera(), TestSchedule(), i, false);
    EXPECT_EQ(frame.config.sequence, want.config.sequence);
    EXPECT_EQ(frame.config.cycle, want.config.cycle);
    EXPECT_EQ(frame.config.harmonic, want.config.harmonic);
    EXPECT_EQ(std::memcmp(frame.pixels.data(), want.pixels.data(), want.pixels.size() * 4), 0);
  }
  EXPECT_THAT(source.Next(kTimeout, &frame),
              StatusIs(absl::StatusCode::kOutOfRange, HasSubstr("end of the recording")));
  EXPECT_THAT(source.GroundTruthAt(0.0).status(),
              StatusIs(absl::StatusCode::kUnimplemented, HasSubstr("no ground truth")));
}

TEST_F(Replay, LoopWrapsWithCyclesSequencesAndTimestampsStillIncreasing) {
  std::unique_ptr<ReplaySource> source = OpenStarted("?pace=fast&loop=1");
  ASSERT_NE(source, nullptr);
  RawFrame frame;
  ExposureConfig previous;
  for (int64_t i = 0; i < 3 * kFrames; ++i) {
    ASSERT_THAT(source->Next(kTimeout, &frame), IsOk());
    if (i > 0) {
      EXPECT_GT(frame.config.sequence, previous.sequence);
      EXPECT_GE(frame.config.cycle, previous.cycle);
      EXPECT_GT(frame.config.timestamp_s, previous.timestamp_s);
    }
    EXPECT_EQ(frame.config.cycle, i / 10);  // the cycle count runs on across passes
    previous = frame.config;
  }
}

TEST_F(Replay, SeekAndStartBeginAtTheCycle) {
  std::unique_ptr<ReplaySource> source = OpenStarted("?pace=fast&start=1");
  ASSERT_NE(source, nullptr);
  RawFrame frame;
  ASSERT_THAT(source->Next(kTimeout, &frame), IsOk());
  EXPECT_EQ(frame.config.sequence, 1010u);
  ASSERT_THAT(source->Seek(2), IsOk());
  ASSERT_THAT(source->Next(kTimeout, &frame), IsOk());
  EXPECT_EQ(frame.config.cycle, 2);
  EXPECT_EQ(frame.config.sequence, 1020u);
  EXPECT_THAT(source->Seek(7), StatusIs(absl::StatusCode::kInvalidArgument,
                                        HasSubstr("cycles 0..2")));
  EXPECT_THAT(ReplaySource::Open(absl::StrCat("replay:", path_, "?start=9")).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("start: cycle 9")));
}

TEST_F(Replay, RealtimePaceWaitsForRecordedTimestamps) {
  const std::string slow = scratch_.File("slow.h5");
  constexpr double kPeriod = 0.02;
  WriteTestCapture(slow, 6, TestOptions(), kPeriod);
  absl::StatusOr<std::unique_ptr<ReplaySource>> source =
      ReplaySource::Open(absl::StrCat("replay:", slow, "?pace=realtime"));
  ASSERT_THAT(source.status(), IsOk());
  const absl::Time begin = absl::Now();  // before the pace's anchor (Start / first frame)
  ASSERT_THAT((*source)->Start(), IsOk());
  RawFrame frame;
  for (int i = 0; i < 6; ++i) ASSERT_THAT((*source)->Next(kTimeout, &frame), IsOk());
  // Only a lower bound: a loaded machine may be slower, never faster.
  EXPECT_GE(absl::Now() - begin, absl::Seconds(5 * kPeriod * 0.9));

  // A frame not due within the timeout is a deadline, and is delivered later.
  const std::string sparse = scratch_.File("sparse.h5");
  WriteTestCapture(sparse, 2, TestOptions(), 10.0);
  source = ReplaySource::Open(absl::StrCat("replay:", sparse));
  ASSERT_THAT(source.status(), IsOk());
  ASSERT_THAT((*source)->Start(), IsOk());
  ASSERT_THAT((*source)->Next(kTimeout, &frame), IsOk());
  EXPECT_THAT((*source)->Next(absl::Milliseconds(10), &frame),
              StatusIs(absl::StatusCode::kDeadlineExceeded, HasSubstr("next frame due")));
}

TEST_F(Replay, UnreadableFrameIsDataLossAndTheReplayGoesOn) {
  const std::string corrupt = scratch_.File("corrupt.h5");
  WriteTestCapture(corrupt, 5, TestOptions(CapturePixelType::kFloat32, 5));
  ASSERT_NO_FATAL_FAILURE(testing::CorruptFrameChunk(corrupt, 2, '\x5A'));
  absl::StatusOr<std::unique_ptr<ReplaySource>> source =
      ReplaySource::Open(absl::StrCat("replay:", corrupt, "?pace=fast"));
  ASSERT_THAT(source.status(), IsOk());
  ASSERT_THAT((*source)->Start(), IsOk());
  RawFrame frame;
  for (int i = 0; i < 5; ++i) {
    if (i == 2) {
      EXPECT_THAT((*source)->Next(kTimeout, &frame), StatusIs(absl::StatusCode::kDataLoss,
                                                             HasSubstr("cannot read frame 2")));
    } else {
      ASSERT_THAT((*source)->Next(kTimeout, &frame), IsOk());
      EXPECT_EQ(frame.config.sequence, 1000u + i);
    }
  }
  EXPECT_EQ((*source)->Next(kTimeout, &frame).code(), absl::StatusCode::kOutOfRange);
}

TEST_F(Replay, GroundTruthOfTheRecording) {
  const std::string simulated = scratch_.File("simulated.h5");
  const GroundTruth truth = testing::TestGroundTruth(TestCamera(), 2, 2);
  {
    absl::StatusOr<CaptureWriter> writer =
        CaptureWriter::Create(simulated, TestCamera(), TestSchedule(), TestOptions());
    ASSERT_THAT(writer.status(), IsOk());
    ASSERT_THAT(writer->SetGroundTruth(truth), IsOk());
    ASSERT_THAT(writer->Append(TestFrame(TestCamera(), TestSchedule(), 0, false)), IsOk());
  }
  absl::StatusOr<std::unique_ptr<ReplaySource>> source =
      ReplaySource::Open(absl::StrCat("replay:", simulated));
  ASSERT_THAT(source.status(), IsOk());
  absl::StatusOr<GroundTruth> got = (*source)->GroundTruthAt(123.0);
  ASSERT_THAT(got.status(), IsOk());
  EXPECT_EQ(got->return_amplitude, truth.return_amplitude);
}

TEST_F(Replay, BadUrisAreRefusedByName) {
  const std::string prefix = absl::StrCat("replay:", path_);
  EXPECT_THAT(ReplaySource::Open(prefix + "?speed=2").status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("unknown key 'speed'; expected loop, pace, start")));
  EXPECT_THAT(ReplaySource::Open(prefix + "?loop=yes").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("loop = 'yes'; expected 0 or 1")));
  EXPECT_THAT(ReplaySource::Open(prefix + "?pace=slow").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("pace = 'slow'")));
  EXPECT_THAT(ReplaySource::Open(prefix + "?start=-3").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("start = '-3'")));
  EXPECT_THAT(ReplaySource::Open("replay:?pace=fast").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("no file path")));
  EXPECT_THAT(ReplaySource::Open(absl::StrCat("replay:", scratch_.File("none.h5"))).status(),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("none.h5: no such file")));
  std::unique_ptr<ReplaySource> source = OpenStarted("");
  ASSERT_NE(source, nullptr);
  EXPECT_THAT(source->Start(), StatusIs(absl::StatusCode::kFailedPrecondition,
                                        HasSubstr("already started")));
}

}  // namespace
}  // namespace transient
