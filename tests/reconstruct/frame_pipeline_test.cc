// The frame pipeline is the steps it names, in their order, and nothing else: Measure equals
// demodulation, calibration and smoothing done by hand, bit for bit; Solve equals Solve; a
// calibration that does not fit is refused at Create and at SetCalibration.
#include "transient/reconstruct/frame_pipeline.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <memory>
#include <random>
#include <vector>

#include "tests/reconstruct/synthetic_cycles.h"
#include "tests/support/status_matchers.h"
#include "transient/reconstruct/smoothing.h"

namespace transient {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

constexpr ImageGeometry kPipelineGeometry{.width = 12, .height = 9};

// The bit patterns of `values`: equal vectors of them mean equal floats, NaN included.
std::vector<uint32_t> Bits(const std::vector<float>& values) {
  std::vector<uint32_t> bits;
  for (float v : values) bits.push_back(std::bit_cast<uint32_t>(v));
  return bits;
}

// Per-pixel complex factors of modulus 0.8..1.2 and any phase, every pixel usable but one.
std::shared_ptr<const CalibrationTable> RandomCalibration(const AcquisitionSchedule& schedule,
                                                          ImageGeometry geometry,
                                                          std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto table = std::make_shared<CalibrationTable>();
  table->geometry = geometry;
  table->order = schedule.order();
  table->base_frequency_hz = schedule.options().base_frequency_hz;
  table->schedule = schedule.options();
  table->takes_averaged = 1;
  const int64_t pixels = geometry.pixel_count();
  for (int j = 0; j <= table->order; ++j) {
    for (int64_t p = 0; p < pixels; ++p) {
      const Complex k = j == 0 ? Complex(1.0, 0.0) : std::polar(0.8 + 0.4 * u(rng), 6.28 * u(rng));
      table->real.push_back(static_cast<float>(k.real()));
      table->imag.push_back(static_cast<float>(k.imag()));
    }
  }
  table->valid.assign(static_cast<size_t>(pixels), 1);
  table->valid[5] = 0;
  return table;
}

TEST(FramePipeline, MeasureIsDemodulationThenCalibrationThenSmoothingBitForBit) {
  std::mt19937_64 rng(11);
  const AcquisitionSchedule schedule =
      testing::MakeSchedule(SamplingScheme::kArccos, 8, ZerothScheme::kUnmodulatedPair, 3);
  const testing::Scene scene = testing::RandomScene(kPipelineGeometry, schedule.order(), rng);
  const auto calibration = RandomCalibration(schedule, kPipelineGeometry, rng);
  constexpr double kSigma = 0.8;
  absl::StatusOr<FramePipeline> pipeline = FramePipeline::Create(
      schedule, kPipelineGeometry, {.calibration = calibration, .smoothing_sigma_px = kSigma}, {});
  ASSERT_THAT(pipeline.status(), IsOk());
  absl::StatusOr<Demodulator> demodulator = Demodulator::Create(schedule, kPipelineGeometry, {});
  ASSERT_THAT(demodulator.status(), IsOk());
  for (int64_t cycle = 0; cycle < 2; ++cycle) {
    const std::vector<RawFrame> frames = testing::SynthesizeCycle(schedule, scene, cycle, 0.5, rng);
    MomentImage measured, expected;
    DemodulationReport report;
    ASSERT_THAT(pipeline->Measure(frames, &measured, &report), IsOk());
    EXPECT_EQ(report.frames_used, schedule.raw_frames_per_frame());
    ASSERT_THAT(demodulator->Demodulate(frames, &expected), IsOk());
    ASSERT_THAT(ApplyCalibration(*calibration, &expected), IsOk());
    ASSERT_THAT(GaussianSmooth(kSigma, &expected), IsOk());
    EXPECT_EQ(Bits(measured.real), Bits(expected.real));
    EXPECT_EQ(Bits(measured.imag), Bits(expected.imag));
    EXPECT_EQ(measured.valid, expected.valid);
    EXPECT_EQ(measured.valid[5], 0) << "the calibration's unusable pixel";
  }
}

TEST(FramePipeline, SolveIsTheCoresSolveWithTheGivenOptions) {
  std::mt19937_64 rng(12);
  const AcquisitionSchedule schedule =
      testing::MakeSchedule(SamplingScheme::kFourBucket, 1, ZerothScheme::kUnmodulatedPair, 1);
  const testing::Scene scene = testing::RandomScene(kPipelineGeometry, schedule.order(), rng);
  const SolveOptions solve{.bias_epsilon = 1e-2, .bias_mode = BiasMode::kScaleMoments};
  absl::StatusOr<FramePipeline> pipeline =
      FramePipeline::Create(schedule, kPipelineGeometry, {.smoothing_sigma_px = 0.0}, solve);
  ASSERT_THAT(pipeline.status(), IsOk());
  MomentImage moments;
  ASSERT_THAT(pipeline->Measure(testing::SynthesizeCycle(schedule, scene, 0, 0.0, rng), &moments),
              IsOk());
  SolvedImage solved;
  pipeline->Solve(moments, &solved);
  const SolvedImage expected = Solve(moments, solve);
  EXPECT_EQ(solved.c_real, expected.c_real);
  EXPECT_EQ(solved.q_imag, expected.q_imag);
  EXPECT_EQ(solved.flags, expected.flags);
}

TEST(FramePipeline, ACalibrationThatDoesNotFitIsRefusedAndTheOldOneKept) {
  std::mt19937_64 rng(13);
  const AcquisitionSchedule schedule =
      testing::MakeSchedule(SamplingScheme::kArccos, 8, ZerothScheme::kUnmodulatedPair, 1);
  const auto other_size = RandomCalibration(schedule, {.width = 10, .height = 9}, rng);
  EXPECT_THAT(
      FramePipeline::Create(schedule, kPipelineGeometry, {.calibration = other_size}, {}).status(),
      StatusIs(absl::StatusCode::kFailedPrecondition, HasSubstr("10x9")));
  const auto fitting = RandomCalibration(schedule, kPipelineGeometry, rng);
  absl::StatusOr<FramePipeline> pipeline =
      FramePipeline::Create(schedule, kPipelineGeometry, {.calibration = fitting}, {});
  ASSERT_THAT(pipeline.status(), IsOk());
  EXPECT_THAT(pipeline->SetCalibration(other_size),
              StatusIs(absl::StatusCode::kFailedPrecondition, HasSubstr("10x9")));
  EXPECT_EQ(pipeline->measure_options().calibration, fitting);
  EXPECT_THAT(pipeline->SetCalibration(nullptr), IsOk());
  EXPECT_EQ(pipeline->measure_options().calibration, nullptr);
}

TEST(FramePipeline, BadOptionsAreRefusedNamingTheField) {
  const AcquisitionSchedule schedule =
      testing::MakeSchedule(SamplingScheme::kArccos, 8, ZerothScheme::kUnmodulatedPair, 1);
  EXPECT_THAT(
      FramePipeline::Create(schedule, kPipelineGeometry, {.smoothing_sigma_px = -1.0}, {}).status(),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("smoothing_sigma_px")));
  EXPECT_THAT(
      FramePipeline::Create(schedule, kPipelineGeometry, {}, {.bias_epsilon = 0.0}).status(),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("bias_epsilon")));
}

TEST(FramePipeline, AnIncompleteCycleIsRefusedAndTheNextOneMeasured) {
  std::mt19937_64 rng(14);
  const AcquisitionSchedule schedule =
      testing::MakeSchedule(SamplingScheme::kArccos, 8, ZerothScheme::kUnmodulatedPair, 1);
  const testing::Scene scene = testing::RandomScene(kPipelineGeometry, schedule.order(), rng);
  absl::StatusOr<FramePipeline> pipeline =
      FramePipeline::Create(schedule, kPipelineGeometry, {}, {});
  ASSERT_THAT(pipeline.status(), IsOk());
  std::vector<RawFrame> incomplete = testing::SynthesizeCycle(schedule, scene, 0, 0.0, rng);
  incomplete.pop_back();
  MomentImage moments;
  EXPECT_THAT(pipeline->Measure(incomplete, &moments),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("missing")));
  EXPECT_THAT(pipeline->Measure(testing::SynthesizeCycle(schedule, scene, 1, 0.0, rng), &moments),
              IsOk());
}

TEST(FramePipeline, TheZerothMomentIsEstimatedExactlyWhenTheScheduleMeasuresNone) {
  ScheduleOptions options;
  EXPECT_EQ(ZerothMomentOf(options), ZerothMoment::kMeasured);
  options.zeroth = ZerothScheme::kLowFrequencyProxy;
  EXPECT_EQ(ZerothMomentOf(options), ZerothMoment::kMeasured);
  options.zeroth = ZerothScheme::kEstimated;
  EXPECT_EQ(ZerothMomentOf(options), ZerothMoment::kEstimate);
}

}  // namespace
}  // namespace transient
