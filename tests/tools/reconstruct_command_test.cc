// `transient reconstruct` in-process: files with known per-pixel measures, written through
// HDF5's C API in every accepted storage variant, come back as the right products.
#include "tools/transient/commands/reconstruct_command.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <numeric>
#include <random>
#include <tuple>

#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "tests/formats/test_files.h"
#include "transient/reconstruct/moments.h"

namespace transient::tools {
namespace {

using ::testing::Each;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsNan;
using ::transient::testing::IsOk;
using testing::MomentStack;
using ::testing::Not;
using testing::ObjectExists;
using testing::ReadFloatDataset;
using testing::ReadRootDoubleAttribute;
using testing::ReadRootStringAttribute;
using testing::ReadUint8Dataset;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;
using testing::StoredFloat;

constexpr double kBaseFrequencyHz = 23e6;
constexpr int kOrder = 8;
constexpr int kFrames = 2;
constexpr ImageGeometry kGeometry = {.width = 6, .height = 5};

// Pisarenko recovers the phases of at most m Diracs exactly from biased moments (raising c_0
// adds a uniform component, which it separates); what is left is float32 storage of the
// moments and of the result: ~1e-6 rad, i.e. ~1e-6 m at 23 MHz. Allow 1 mm.
constexpr double kPisarenkoRangeTolerance = 1e-3;
// The MESE peak of a Dirac is pulled by its neighbours and by the uniform component added by
// biasing (eps = 4e-3); for returns >= 0.9 rad apart at m = 8 the shift stays below 1 cm.
constexpr double kMeseRangeTolerance = 1e-2;
// float32 storage of c_0 in and out.
constexpr double kZerothRelativeTolerance = 1e-6;
// /density holds point samples of D. A Riemann sum over N bins of D(phi) exp(i j phi) misses
// the aliased Fourier coefficients of D at N - j, N + j, ..., which decay like rho^-N with the
// distance rho - 1 of q's roots from the unit circle. For the smooth measures of
// ReconstructSmoothMeasures they are far out and float32 storage of D dominates (~1e-7 per
// sample); for sparse measures at eps = 4e-3 the peaks are milliradians wide and no grid of a
// reasonable size integrates them (see README.md), so the sparse tests do not sum densities.
constexpr double kDensityMomentRelativeTolerance = 1e-5;
// F_D([0, phi_{N-1}]) misses the mass of the last 1/N of the circle: the uniform share
// (~eps * c_0) plus the tails of the peaks.
constexpr double kCumulativeEndRelativeTolerance = 2e-2;

struct Return {
  double phase;
  double weight;
};

// A stack whose pixels hold 1 to 3 Dirac returns: the first is the strongest, the later ones
// are weaker and at least 0.9 rad apart.
struct Scene {
  MomentStack stack{kFrames, kOrder, kGeometry};
  std::vector<double> first_range_m;  // per frame and pixel
  std::vector<double> c0;             // per frame and pixel
};

Scene MakeScene(uint64_t seed) {
  Scene scene;
  MomentStack& stack = scene.stack;
  stack.base_frequency_hz = kBaseFrequencyHz;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> first_phase(0.4, 2.4), gap(0.9, 1.4);
  std::uniform_real_distribution<double> brightness(0.5, 2.0), echo(0.2, 0.45);
  std::uniform_int_distribution<int> count(1, 3);
  const int64_t pixels = kGeometry.pixel_count();
  std::vector<Complex> c(kOrder + 1);
  for (int frame = 0; frame < kFrames; ++frame) {
    for (int64_t p = 0; p < pixels; ++p) {
      const double b = brightness(rng);
      std::vector<double> phases = {first_phase(rng)}, weights = {b};
      const int returns = count(rng);
      while (static_cast<int>(phases.size()) < returns) {
        phases.push_back(phases.back() + gap(rng));
        weights.push_back(b * echo(rng));
      }
      DiracMoments(phases, weights, c);
      for (int j = 0; j <= kOrder; ++j) {
        stack.real[stack.index(frame, j, p)] = c[j].real();
        stack.imag[stack.index(frame, j, p)] = c[j].imag();
      }
      scene.first_range_m.push_back(PhaseToRange(phases[0], kBaseFrequencyHz));
      scene.c0.push_back(std::accumulate(weights.begin(), weights.end(), 0.0));
    }
  }
  return scene;
}

// Pixels broken on purpose: (frame, pixel) with NaN moments, masked invalid, no light; and a
// valid pixel with uniform light (c_1..c_m = 0), which has no return.
constexpr int64_t kNaNPixel = 0;      // frame 0
constexpr int64_t kMaskedPixel = 1;   // frame 1
constexpr int64_t kDarkPixel = 2;     // frame 1
constexpr int64_t kUniformPixel = 3;  // frame 0
int64_t At(int frame, int64_t pixel) { return frame * kGeometry.pixel_count() + pixel; }

void BreakPixels(Scene& scene, bool with_mask) {
  MomentStack& stack = scene.stack;
  stack.real[stack.index(0, 1, kNaNPixel)] = std::numeric_limits<double>::quiet_NaN();
  for (int j = 0; j <= kOrder; ++j) {
    stack.real[stack.index(1, j, kDarkPixel)] = 0.0;
    stack.imag[stack.index(1, j, kDarkPixel)] = 0.0;
    stack.real[stack.index(0, j, kUniformPixel)] = j == 0 ? 1.0 : 0.0;
    stack.imag[stack.index(0, j, kUniformPixel)] = 0.0;
  }
  if (with_mask) {
    stack.valid.assign(kFrames * kGeometry.pixel_count(), 1);
    stack.valid[At(1, kMaskedPixel)] = 0;
  }
}

bool IsBroken(int64_t frame_pixel, bool with_mask) {
  return frame_pixel == At(0, kNaNPixel) || frame_pixel == At(1, kDarkPixel) ||
         (with_mask && frame_pixel == At(1, kMaskedPixel));
}

// The pixels whose known first return the tests compare with.
bool HasReturn(int64_t frame_pixel, bool with_mask) {
  return !IsBroken(frame_pixel, with_mask) && frame_pixel != At(0, kUniformPixel);
}

// float32 or float64 storage, with or without /moments/valid.
class ReconstructRoundTrip : public ::testing::TestWithParam<std::tuple<StoredFloat, bool>> {
 protected:
  void SetUp() override {
    scene_ = MakeScene(/*seed=*/20240611);
    BreakPixels(scene_, with_mask());
    testing::WriteMomentFile(input(), scene_.stack, {.type = std::get<0>(GetParam())});
    args_.input_path = input();
    args_.output_path = output();
    summary_ = RunReconstruct(args_);
    ASSERT_THAT(summary_.status(), IsOk());
  }

  bool with_mask() const { return std::get<1>(GetParam()); }
  std::string input() const { return dir_.File("in.h5"); }
  std::string output() const { return dir_.File("out.h5"); }
  int64_t frame_pixels() const { return kFrames * kGeometry.pixel_count(); }

  ScratchDirectory dir_;
  Scene scene_;
  ReconstructArgs args_;
  absl::StatusOr<ReconstructSummary> summary_;
};

TEST_P(ReconstructRoundTrip, LeavesOnlyTheOutputBesideTheInput) {
  EXPECT_THAT(dir_.Entries(), ElementsAre("in.h5", "out.h5"));
}

TEST_P(ReconstructRoundTrip, MeseRangeIsTheFirstReturnOfEveryValidPixel) {
  const std::vector<float> range = ReadFloatDataset(output(), "/range_m");
  ASSERT_EQ(range.size(), static_cast<size_t>(frame_pixels()));
  for (int64_t i = 0; i < frame_pixels(); ++i) {
    if (!HasReturn(i, with_mask())) continue;
    EXPECT_NEAR(range[i], scene_.first_range_m[i], kMeseRangeTolerance) << "frame-pixel " << i;
  }
}

TEST_P(ReconstructRoundTrip, PisarenkoRangeIsTheFirstReturnOfEveryValidPixel) {
  const std::vector<float> range = ReadFloatDataset(output(), "/pisarenko/range_m");
  ASSERT_EQ(range.size(), static_cast<size_t>(frame_pixels()));
  for (int64_t i = 0; i < frame_pixels(); ++i) {
    if (!HasReturn(i, with_mask())) continue;
    EXPECT_NEAR(range[i], scene_.first_range_m[i], kPisarenkoRangeTolerance) << "frame-pixel " << i;
  }
}

TEST_P(ReconstructRoundTrip, ZerothMomentIsTheMeasuredOneRaisedByBiasing) {
  // A few Diracs make C(c) singular (lambda_min = 0), so raising c_0 by
  // (eps * c_0 - 0) / (1 - eps) gives c_0 / (1 - eps) for every valid pixel.
  const std::vector<float> c0 = ReadFloatDataset(output(), "/c0");
  const std::vector<uint8_t> flags = ReadUint8Dataset(output(), "/flags");
  for (int64_t i = 0; i < frame_pixels(); ++i) {
    if (!HasReturn(i, with_mask())) continue;
    const double expected = scene_.c0[i] / (1.0 - args_.bias_epsilon);
    EXPECT_NEAR(c0[i], expected, kZerothRelativeTolerance * expected) << "frame-pixel " << i;
    EXPECT_EQ(flags[i], kFlagBiased) << "frame-pixel " << i;
  }
}

TEST_P(ReconstructRoundTrip, CumulativeRisesToTheZerothMoment) {
  const std::vector<float> cumulative = ReadFloatDataset(output(), "/cumulative");
  const std::vector<float> c0 = ReadFloatDataset(output(), "/c0");
  const int64_t pixels = kGeometry.pixel_count();
  for (int frame = 0; frame < kFrames; ++frame) {
    for (int64_t p = 0; p < pixels; ++p) {
      if (!HasReturn(At(frame, p), with_mask())) continue;
      const auto at = [&](int n) {
        return cumulative[(int64_t{frame} * args_.bins + n) * pixels + p];
      };
      EXPECT_NEAR(at(0), 0.0f, 1e-6 * c0[At(frame, p)]);
      for (int n = 1; n < args_.bins; ++n) ASSERT_GE(at(n), at(n - 1)) << "bin " << n;
      EXPECT_NEAR(at(args_.bins - 1), c0[At(frame, p)],
                  kCumulativeEndRelativeTolerance * c0[At(frame, p)]);
    }
  }
}

TEST_P(ReconstructRoundTrip, BrokenPixelsAreFlaggedInvalidAndHaveNoProducts) {
  const std::vector<uint8_t> flags = ReadUint8Dataset(output(), "/flags");
  const std::vector<float> range = ReadFloatDataset(output(), "/range_m");
  const std::vector<float> c0 = ReadFloatDataset(output(), "/c0");
  const std::vector<float> density = ReadFloatDataset(output(), "/density");
  const std::vector<float> direct = ReadFloatDataset(output(), "/pisarenko/direct");
  for (int64_t i = 0; i < frame_pixels(); ++i) {
    if (!IsBroken(i, with_mask())) continue;
    EXPECT_EQ(flags[i], kFlagInvalidInput) << "frame-pixel " << i;
    EXPECT_TRUE(std::isnan(range[i]));
    EXPECT_TRUE(std::isnan(c0[i]));
    EXPECT_TRUE(std::isnan(direct[i]));
  }
  EXPECT_TRUE(std::isnan(density[kNaNPixel]));  // frame 0, bin 0
  EXPECT_EQ(summary_->invalid, with_mask() ? 3 : 2);
  EXPECT_EQ(summary_->biased, frame_pixels() - summary_->invalid - 1);  // all but uniform
}

TEST_P(ReconstructRoundTrip, UniformLightHasNoReturnButKeepsItsZerothMoment) {
  const int64_t i = At(0, kUniformPixel);
  EXPECT_EQ(ReadUint8Dataset(output(), "/flags")[i], kFlagNoReturn);
  EXPECT_TRUE(std::isnan(ReadFloatDataset(output(), "/range_m")[i]));
  EXPECT_EQ(ReadFloatDataset(output(), "/c0")[i], 1.0f);  // C(c) = I: nothing to bias
  // MESE of uniform moments is the uniform density c_0 / (2*pi).
  const std::vector<float> density = ReadFloatDataset(output(), "/density");
  EXPECT_NEAR(density[i], 1.0 / kTwoPi, 1e-6);
  EXPECT_EQ(summary_->no_return, 1);
}

TEST_P(ReconstructRoundTrip, RangeIsNaNExactlyWhereFlagsSayWhy) {
  const std::vector<uint8_t> flags = ReadUint8Dataset(output(), "/flags");
  const std::vector<float> range = ReadFloatDataset(output(), "/range_m");
  for (int64_t i = 0; i < frame_pixels(); ++i) {
    EXPECT_EQ(std::isnan(range[i]), (flags[i] & (kFlagInvalidInput | kFlagNoReturn)) != 0)
        << "frame-pixel " << i;
  }
}

TEST_P(ReconstructRoundTrip, PisarenkoPhasesAreSortedAndWeightsAddUpToTheZerothMoment) {
  const std::vector<float> phase = ReadFloatDataset(output(), "/pisarenko/phase");
  const std::vector<float> weight = ReadFloatDataset(output(), "/pisarenko/weight");
  const std::vector<float> uniform = ReadFloatDataset(output(), "/pisarenko/uniform");
  const std::vector<float> c0 = ReadFloatDataset(output(), "/c0");
  const int64_t pixels = kGeometry.pixel_count();
  for (int frame = 0; frame < kFrames; ++frame) {
    for (int64_t p = 0; p < pixels; ++p) {
      if (!HasReturn(At(frame, p), with_mask())) continue;
      double total = uniform[At(frame, p)];
      for (int l = 0; l < kOrder; ++l) {
        const int64_t i = (int64_t{frame} * kOrder + l) * pixels + p;
        if (std::isnan(weight[i])) break;
        total += weight[i];
        if (l > 0) {
          EXPECT_GE(phase[i], phase[i - pixels]);
        }
      }
      EXPECT_NEAR(total, c0[At(frame, p)], kZerothRelativeTolerance * 10 * c0[At(frame, p)]);
    }
  }
}

TEST_P(ReconstructRoundTrip, WritesTheDocumentedAttributesAndShapes) {
  EXPECT_EQ(ReadRootStringAttribute(output(), "format"), "transient-reconstruction 1");
  EXPECT_EQ(ReadRootDoubleAttribute(output(), "base_frequency_hz"), kBaseFrequencyHz);
  EXPECT_EQ(ReadRootDoubleAttribute(output(), "bins"), 256);
  EXPECT_EQ(ReadRootStringAttribute(output(), "method"), "both");
  EXPECT_EQ(ReadRootDoubleAttribute(output(), "bias_epsilon"), 4e-3);
  EXPECT_EQ(ReadRootStringAttribute(output(), "bias_mode"), "raise");
  EXPECT_EQ(ReadRootStringAttribute(output(), "zeroth"), "measured");
  EXPECT_EQ(ReadRootDoubleAttribute(output(), "threshold"), 0.1);
  EXPECT_EQ(ReadRootDoubleAttribute(output(), "order"), kOrder);
  EXPECT_EQ(ReadRootDoubleAttribute(output(), "first_frame"), 0);
  EXPECT_EQ(ReadRootStringAttribute(output(), "source"), input());

  const hsize_t f = kFrames, h = kGeometry.height, w = kGeometry.width, m = kOrder, bins = 256;
  const std::vector<std::pair<std::string, std::vector<hsize_t>>> expected = {
      {"/range_m", {f, h, w}},
      {"/c0", {f, h, w}},
      {"/flags", {f, h, w}},
      {"/density", {f, bins, h, w}},
      {"/cumulative", {f, bins, h, w}},
      {"/phase_rad", {bins}},
      {"/pisarenko/phase", {f, m, h, w}},
      {"/pisarenko/weight", {f, m, h, w}},
      {"/pisarenko/uniform", {f, h, w}},
      {"/pisarenko/range_m", {f, h, w}},
      {"/pisarenko/direct", {f, h, w}},
      {"/pisarenko/indirect", {f, h, w}},
  };
  for (const auto& [name, shape] : expected) {
    std::vector<hsize_t> dims;
    ReadFloatDataset(output(), name, &dims);
    EXPECT_EQ(dims, shape) << name;
  }
  EXPECT_FALSE(ObjectExists(output(), "/bounds"));
}

INSTANTIATE_TEST_SUITE_P(
    StorageVariants, ReconstructRoundTrip,
    ::testing::Combine(::testing::Values(StoredFloat::kFloat32, StoredFloat::kFloat64),
                       ::testing::Bool()),
    [](const ::testing::TestParamInfo<ReconstructRoundTrip::ParamType>& info) {
      return std::string(std::get<0>(info.param) == StoredFloat::kFloat32 ? "Float32" : "Float64") +
             (std::get<1>(info.param) ? "WithMask" : "WithoutMask");
    });

// Runs with a few options on the round-trip scene, without broken pixels.
class ReconstructOptions : public ::testing::Test {
 protected:
  void SetUp() override {
    scene_ = MakeScene(/*seed=*/7);
    testing::WriteMomentFile(input(), scene_.stack);
    args_.input_path = input();
    args_.output_path = output();
  }
  std::string input() const { return dir_.File("in.h5"); }
  std::string output() const { return dir_.File("out.h5"); }

  ScratchDirectory dir_;
  Scene scene_;
  ReconstructArgs args_;
};

TEST_F(ReconstructOptions, MethodMeseWritesNoPisarenkoGroup) {
  args_.method = Method::kMese;
  ASSERT_THAT(RunReconstruct(args_).status(), IsOk());
  EXPECT_TRUE(ObjectExists(output(), "/density"));
  EXPECT_FALSE(ObjectExists(output(), "/pisarenko"));
  EXPECT_EQ(ReadRootStringAttribute(output(), "method"), "mese");
}

TEST_F(ReconstructOptions, MethodPisarenkoTakesItsRangeAndWritesNoMeseProducts) {
  args_.method = Method::kPisarenko;
  ASSERT_THAT(RunReconstruct(args_).status(), IsOk());
  EXPECT_FALSE(ObjectExists(output(), "/density"));
  EXPECT_FALSE(ObjectExists(output(), "/cumulative"));
  EXPECT_FALSE(ObjectExists(output(), "/phase_rad"));
  const std::vector<float> range = ReadFloatDataset(output(), "/range_m");
  EXPECT_EQ(range, ReadFloatDataset(output(), "/pisarenko/range_m"));
  for (size_t i = 0; i < range.size(); ++i) {
    EXPECT_NEAR(range[i], scene_.first_range_m[i], kPisarenkoRangeTolerance);
  }
}

TEST_F(ReconstructOptions, BoundsRWritesBoundsThatAreOrdered) {
  args_.bounds_r = 0.8;
  args_.bins = 64;
  ASSERT_THAT(RunReconstruct(args_).status(), IsOk());
  EXPECT_EQ(ReadRootDoubleAttribute(output(), "bounds_r"), 0.8);
  std::vector<hsize_t> dims;
  const std::vector<float> lower = ReadFloatDataset(output(), "/bounds/lower", &dims);
  const std::vector<float> upper = ReadFloatDataset(output(), "/bounds/upper");
  EXPECT_EQ(dims, (std::vector<hsize_t>{kFrames, 64, kGeometry.height, kGeometry.width}));
  ASSERT_EQ(lower.size(), upper.size());
  for (size_t i = 0; i < lower.size(); ++i) {
    EXPECT_LE(lower[i], upper[i]) << i;
    EXPECT_GE(lower[i], 0.0f) << i;
  }
}

TEST_F(ReconstructOptions, FramesSliceWritesTheSelectedFramesAndRecordsTheFirst) {
  args_.frames = {.start = -1};
  ASSERT_THAT(RunReconstruct(args_).status(), IsOk());
  EXPECT_EQ(ReadRootDoubleAttribute(output(), "first_frame"), 1);
  std::vector<hsize_t> dims;
  const std::vector<float> range = ReadFloatDataset(output(), "/pisarenko/range_m", &dims);
  EXPECT_EQ(dims, (std::vector<hsize_t>{1, kGeometry.height, kGeometry.width}));
  for (int64_t p = 0; p < kGeometry.pixel_count(); ++p) {
    EXPECT_NEAR(range[p], scene_.first_range_m[At(1, p)], kPisarenkoRangeTolerance);
  }
}

TEST_F(ReconstructOptions, EstimatedZerothMomentStillFindsTheFirstReturn) {
  args_.zeroth = ZerothMoment::kEstimate;
  ASSERT_THAT(RunReconstruct(args_).status(), IsOk());
  EXPECT_EQ(ReadRootStringAttribute(output(), "zeroth"), "estimate");
  const std::vector<float> range = ReadFloatDataset(output(), "/pisarenko/range_m");
  for (size_t i = 0; i < range.size(); ++i) {
    EXPECT_NEAR(range[i], scene_.first_range_m[i], kPisarenkoRangeTolerance);
  }
}

TEST_F(ReconstructOptions, ScaleBiasModeKeepsTheMeasuredZerothMoment) {
  args_.bias_mode = BiasMode::kScaleMoments;
  ASSERT_THAT(RunReconstruct(args_).status(), IsOk());
  EXPECT_EQ(ReadRootStringAttribute(output(), "bias_mode"), "scale");
  const std::vector<float> c0 = ReadFloatDataset(output(), "/c0");
  for (size_t i = 0; i < c0.size(); ++i) {
    EXPECT_NEAR(c0[i], scene_.c0[i], kZerothRelativeTolerance * scene_.c0[i]);
  }
}

TEST_F(ReconstructOptions, ProgressHookSeesEveryFrameInOrder) {
  std::vector<std::pair<int64_t, int64_t>> calls;
  ASSERT_THAT(
      RunReconstruct(args_, {.on_progress = [&](int64_t done,
                                             int64_t total) { calls.emplace_back(done, total); }})
          .status(),
      IsOk());
  EXPECT_THAT(calls,
              ElementsAre(std::pair<int64_t, int64_t>{1, 2}, std::pair<int64_t, int64_t>{2, 2}));
}

TEST_F(ReconstructOptions, SummaryCountsFramesAndPixels) {
  absl::StatusOr<ReconstructSummary> summary = RunReconstruct(args_);
  ASSERT_THAT(summary.status(), IsOk());
  EXPECT_EQ(summary->frames, kFrames);
  EXPECT_EQ(summary->pixels, kFrames * kGeometry.pixel_count());
  EXPECT_EQ(summary->invalid, 0);
  EXPECT_THAT(FormatSummary(*summary),
              HasSubstr("2 frames of 6x5 px (60 pixels), m=8, both: 100.0% biased, 0.0% "
                        "invalid, 0.0% no return"));
}

TEST_F(ReconstructOptions, InterruptedRunLeavesNoOutput) {
  std::atomic<bool> cancel{false};
  const absl::Status status =
      RunReconstruct(args_,
                     {.on_progress = [&](int64_t, int64_t) { cancel = true; }, .cancel = &cancel})
          .status();
  EXPECT_THAT(status, StatusIs(absl::StatusCode::kCancelled, HasSubstr("interrupted")));
  EXPECT_THAT(dir_.Entries(), ElementsAre("in.h5"));
}

TEST_F(ReconstructOptions, BlocksOfBinsAddUpToTheSameFile) {
  args_.bins = 8;
  args_.bounds_r = 0.5;
  ASSERT_THAT(RunReconstruct(args_).status(), IsOk());
  ReconstructArgs blocked = args_;
  blocked.output_path = dir_.File("blocked.h5");
  blocked.max_block_values = 3 * kGeometry.pixel_count() + 1;  // blocks of 3, 3 and 2 bins
  ASSERT_THAT(RunReconstruct(blocked).status(), IsOk());
  for (const char* name : {"/density", "/cumulative", "/bounds/lower", "/bounds/upper"}) {
    const std::vector<float> whole = ReadFloatDataset(output(), name);
    EXPECT_EQ(ReadFloatDataset(blocked.output_path, name), whole) << name;
    EXPECT_THAT(whole, Each(Not(IsNan()))) << name;
  }
}

TEST_F(ReconstructOptions, ReplacesAnExistingOutput) {
  std::ofstream(output()) << "an old result";
  ASSERT_THAT(RunReconstruct(args_).status(), IsOk());
  EXPECT_EQ(ReadRootStringAttribute(output(), "format"), "transient-reconstruction 1");
}

// Pixels whose measure is smooth: an exponentially modified Gaussian of phase spread 0.3 to
// 0.6 rad, whose moments are exact (its characteristic function at integer j).
class ReconstructSmoothMeasures : public ::testing::Test {
 protected:
  static constexpr int kSmoothOrder = 4;

  void SetUp() override {
    std::mt19937_64 rng(/*seed=*/99);
    std::uniform_real_distribution<double> onset(0.0, kTwoPi), spread(0.3, 0.6);
    std::uniform_real_distribution<double> rate(0.5, 2.0), weight(0.5, 2.0);
    const int64_t pixels = kGeometry.pixel_count();
    for (int64_t p = 0; p < pixels; ++p) {
      const double mu = onset(rng), sigma = spread(rng), lambda = rate(rng), w = weight(rng);
      for (int j = 0; j <= kSmoothOrder; ++j) {
        const Complex c = w * std::exp(Complex(-0.5 * j * j * sigma * sigma, j * mu)) * lambda /
                          Complex(lambda, -j);
        stack_.real[stack_.index(0, j, p)] = c.real();
        stack_.imag[stack_.index(0, j, p)] = c.imag();
      }
    }
    testing::WriteMomentFile(dir_.File("in.h5"), stack_, {.type = StoredFloat::kFloat64});
    args_ = {.input_path = dir_.File("in.h5"), .output_path = dir_.File("out.h5")};
  }

  ScratchDirectory dir_;
  MomentStack stack_{1, kSmoothOrder, kGeometry};
  ReconstructArgs args_;
};

TEST_F(ReconstructSmoothMeasures, DensityReproducesTheInputMomentsOnTheDefaultGrid) {
  // MESE is moment-consistent (thesis eq. 8.3): integrating D(phi) exp(i j phi) gives back
  // c_j for j = 1..m, and c_0 after biasing (raising c_0 only adds a uniform component).
  ASSERT_THAT(RunReconstruct(args_).status(), IsOk());
  const std::vector<float> density = ReadFloatDataset(dir_.File("out.h5"), "/density");
  const std::vector<float> c0 = ReadFloatDataset(dir_.File("out.h5"), "/c0");
  const int64_t pixels = kGeometry.pixel_count();
  const int bins = args_.bins;
  for (int64_t p = 0; p < pixels; ++p) {
    for (int j = 0; j <= kSmoothOrder; ++j) {
      Complex sum = 0.0;
      for (int n = 0; n < bins; ++n) {
        sum +=
            static_cast<double>(density[n * pixels + p]) * std::polar(1.0, j * kTwoPi * n / bins);
      }
      sum *= kTwoPi / bins;
      const Complex expected =
          j == 0 ? Complex(c0[p], 0.0)
                 : Complex(stack_.real[stack_.index(0, j, p)], stack_.imag[stack_.index(0, j, p)]);
      EXPECT_LE(std::abs(sum - expected), kDensityMomentRelativeTolerance * c0[p])
          << "pixel " << p << " moment " << j << ": " << sum << " vs " << expected;
    }
  }
}

TEST_F(ReconstructSmoothMeasures, CumulativeOfTheLastBinIsTheZerothMomentLessTheLastBin) {
  ASSERT_THAT(RunReconstruct(args_).status(), IsOk());
  const std::vector<float> density = ReadFloatDataset(dir_.File("out.h5"), "/density");
  const std::vector<float> cumulative = ReadFloatDataset(dir_.File("out.h5"), "/cumulative");
  const std::vector<float> c0 = ReadFloatDataset(dir_.File("out.h5"), "/c0");
  const int64_t pixels = kGeometry.pixel_count();
  const int last = args_.bins - 1;
  const double bin_width = kTwoPi / args_.bins;
  for (int64_t p = 0; p < pixels; ++p) {
    // F([0, phi_{N-1}]) = c_0 - mass of [phi_{N-1}, 2*pi), which for a smooth density is
    // about the trapezoid between the last sample and the first (phi = 2*pi).
    const double last_bin_mass = 0.5 * bin_width * (density[last * pixels + p] + density[p]);
    EXPECT_NEAR(cumulative[last * pixels + p] + last_bin_mass, c0[p],
                kDensityMomentRelativeTolerance * c0[p] + 1e-3 * last_bin_mass)
        << "pixel " << p;
  }
}

}  // namespace
}  // namespace transient::tools
