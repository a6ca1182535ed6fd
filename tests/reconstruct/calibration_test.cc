#include "transient/reconstruct/calibration.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "tests/support/status_matchers.h"

namespace transient {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

// Factors and moments are float32: a division, a product and the conversions cost a few ulps.
constexpr double kFloatRelative = 1e-5;

ScheduleOptions Schedule(ZerothScheme zeroth = ZerothScheme::kUnmodulatedPair, int order = 3) {
  ScheduleOptions options;
  options.order = order;
  options.zeroth = zeroth;
  return options;
}

// Per-pixel, per-harmonic complex gains of an uncalibrated sensor: amplitude 0.5..1.5 and any
// phase offset (thesis §8.3.2: both need per-pixel calibration).
std::vector<std::vector<Complex>> RandomGains(int64_t pixels, int order, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<std::vector<Complex>> gain(static_cast<size_t>(order + 1),
                                         std::vector<Complex>(static_cast<size_t>(pixels), 1.0));
  for (int j = 1; j <= order; ++j) {
    for (Complex& g : gain[j]) g = std::polar(0.5 + u(rng), 2.0 * std::numbers::pi * u(rng));
  }
  return gain;
}

MomentImage FromComplex(ImageGeometry geometry, const std::vector<std::vector<Complex>>& c) {
  MomentImage image(geometry, static_cast<int>(c.size()) - 1);
  for (size_t j = 0; j < c.size(); ++j) {
    for (int64_t p = 0; p < geometry.pixel_count(); ++p) {
      image.real_plane(static_cast<int>(j))[p] = static_cast<float>(c[j][p].real());
      image.imag_plane(static_cast<int>(j))[p] = j == 0 ? 0.0f : static_cast<float>(c[j][p].imag());
    }
  }
  return image;
}

// The measurement of a Dirac at zero with c_0 in [5, 10] through `gain`, plus complex noise of
// standard deviation `sigma` per component.
MomentImage MeasureDirac(ImageGeometry geometry, const std::vector<std::vector<Complex>>& gain,
                         double sigma, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, sigma);
  std::vector<std::vector<Complex>> c(
      gain.size(), std::vector<Complex>(static_cast<size_t>(geometry.pixel_count())));
  for (int64_t p = 0; p < geometry.pixel_count(); ++p) {
    const double c0 = 5.0 + 5.0 * u(rng);
    c[0][p] = c0 + noise(rng);
    for (size_t j = 1; j < gain.size(); ++j) {
      c[j][p] = gain[j][p] * c0 + Complex(noise(rng), noise(rng));
    }
  }
  return FromComplex(geometry, c);
}

// A scene's true moments: two returns per pixel at random phases with random weights.
std::vector<std::vector<Complex>> SceneMoments(int64_t pixels, int order, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<std::vector<Complex>> c(static_cast<size_t>(order + 1),
                                      std::vector<Complex>(static_cast<size_t>(pixels)));
  for (int64_t p = 0; p < pixels; ++p) {
    const double w0 = 1.0 + 4.0 * u(rng), w1 = 2.0 * u(rng);
    const double phi0 = 2.0 * std::numbers::pi * u(rng), phi1 = 2.0 * std::numbers::pi * u(rng);
    for (int j = 0; j <= order; ++j) {
      c[j][p] = w0 * std::polar(1.0, j * phi0) + w1 * std::polar(1.0, j * phi1);
    }
  }
  return c;
}

std::vector<std::vector<Complex>> Distort(const std::vector<std::vector<Complex>>& c,
                                          const std::vector<std::vector<Complex>>& gain) {
  std::vector<std::vector<Complex>> out = c;
  for (size_t j = 1; j < c.size(); ++j) {
    for (size_t p = 0; p < c[j].size(); ++p) out[j][p] *= gain[j][p];
  }
  return out;
}

TEST(Calibration, RemovesPerPixelGainsAndPhaseOffsetsToFloatPrecision) {
  const ImageGeometry geometry{9, 7};
  const int64_t n = geometry.pixel_count();
  std::mt19937_64 rng(21);
  const auto gain = RandomGains(n, 3, rng);
  absl::StatusOr<CalibrationTable> table =
      EstimateCalibration(MeasureDirac(geometry, gain, 0.0, rng), Schedule(), 4);
  ASSERT_THAT(table.status(), IsOk());
  ASSERT_THAT(table->Validate(), IsOk());
  EXPECT_EQ(table->takes_averaged, 4);
  EXPECT_EQ(table->order, 3);
  const auto truth = SceneMoments(n, 3, rng);
  MomentImage moments = FromComplex(geometry, Distort(truth, gain));
  ASSERT_THAT(ApplyCalibration(*table, &moments), IsOk());
  for (int64_t p = 0; p < n; ++p) {
    ASSERT_EQ(moments.valid[p], 1);
    EXPECT_EQ(table->real[p], 1.0f);  // k_0 = 1: c_0 defines the unit
    for (int j = 0; j <= 3; ++j) {
      const Complex got(moments.real_plane(j)[p], j == 0 ? 0.0f : moments.imag_plane(j)[p]);
      EXPECT_LT(std::abs(got - truth[j][p]), kFloatRelative * std::abs(truth[0][p]))
          << p << " " << j;
    }
  }
}

TEST(Calibration, NoisyCalibrationLeavesErrorsAtTheNoiseLevel) {
  const ImageGeometry geometry{32, 32};
  const int64_t n = geometry.pixel_count();
  constexpr double kSigma = 0.01;  // per component of the averaged calibration moments
  std::mt19937_64 rng(22);
  const auto gain = RandomGains(n, 3, rng);
  absl::StatusOr<CalibrationTable> table =
      EstimateCalibration(MeasureDirac(geometry, gain, kSigma, rng), Schedule(), 16);
  ASSERT_THAT(table.status(), IsOk());
  const auto truth = SceneMoments(n, 3, rng);
  MomentImage moments = FromComplex(geometry, Distort(truth, gain));
  ASSERT_THAT(ApplyCalibration(*table, &moments), IsOk());
  double calibrated = 0.0, uncalibrated = 0.0;
  for (int64_t p = 0; p < n; ++p) {
    const Complex got(moments.real_plane(2)[p], moments.imag_plane(2)[p]);
    // Relative error of k_2 = c_0 / c_2: that of c_0 plus that of c_2, each ~ sigma / c_0 with
    // c_0 >= 5 and |c_2| >= 2.5.
    calibrated += std::norm((got - truth[2][p]) / std::abs(truth[2][p]));
    uncalibrated += std::norm((gain[2][p] - 1.0));
  }
  const double rms = std::sqrt(calibrated / n);
  constexpr double kNoiseBound = 3.0 * kSigma / 2.5 * 1.5;  // sqrt(2) components, 3x margin
  EXPECT_LT(rms, kNoiseBound);
  EXPECT_GT(rms, 0.1 * kSigma / 10.0);  // the noise did reach the result
  EXPECT_GT(std::sqrt(uncalibrated / n), 100.0 * rms);
}

TEST(Calibration, WithEstimatedZerothOnlyRelativeGainsAreCorrected) {
  const ImageGeometry geometry{5, 4};
  const int64_t n = geometry.pixel_count();
  std::mt19937_64 rng(23);
  const auto gain = RandomGains(n, 3, rng);
  absl::StatusOr<CalibrationTable> table = EstimateCalibration(
      MeasureDirac(geometry, gain, 0.0, rng), Schedule(ZerothScheme::kEstimated), 1);
  ASSERT_THAT(table.status(), IsOk());
  const auto truth = SceneMoments(n, 3, rng);
  MomentImage moments = FromComplex(geometry, Distort(truth, gain));
  ASSERT_THAT(ApplyCalibration(*table, &moments), IsOk());
  for (int64_t p = 0; p < n; ++p) {
    // Reference |c_1|: k_1 has unit modulus, and every harmonic comes out scaled by |gain_1|.
    EXPECT_NEAR(std::abs(Complex(table->real[n + p], table->imag[n + p])), 1.0, kFloatRelative);
    for (int j = 1; j <= 3; ++j) {
      const Complex got(moments.real_plane(j)[p], moments.imag_plane(j)[p]);
      EXPECT_LT(std::abs(got - std::abs(gain[1][p]) * truth[j][p]),
                kFloatRelative * 2.0 * std::abs(truth[0][p]));
    }
  }
}

// A camera's harmonic set (the Kinect v2's 2, 10, 15 of 8 MHz, c_0 estimated): the factors of
// the measured harmonics, referenced to the lowest one's modulus; the others' are 1.
TEST(Calibration, AHarmonicSetIsReferencedToItsLowestHarmonic) {
  const ImageGeometry geometry{5, 4};
  const int64_t n = geometry.pixel_count();
  std::mt19937_64 rng(27);
  ScheduleOptions kinect = Schedule(ZerothScheme::kEstimated, 15);
  kinect.harmonics = {10, 2, 15};
  kinect.buckets = 3;
  auto gain = RandomGains(n, 15, rng);
  MomentImage dirac = MeasureDirac(geometry, gain, 0.0, rng);
  for (int j = 1; j <= 15; ++j) {  // unmeasured harmonics hold 0, like the demodulator's
    if (j == 2 || j == 10 || j == 15) continue;
    std::fill_n(dirac.real_plane(j), n, 0.0f);
    std::fill_n(dirac.imag_plane(j), n, 0.0f);
  }
  absl::StatusOr<CalibrationTable> table = EstimateCalibration(dirac, kinect, 1);
  ASSERT_THAT(table.status(), IsOk());
  const auto truth = SceneMoments(n, 15, rng);
  MomentImage moments = FromComplex(geometry, Distort(truth, gain));
  ASSERT_THAT(ApplyCalibration(*table, &moments), IsOk());
  for (int64_t p = 0; p < n; ++p) {
    ASSERT_EQ(table->valid[p], 1);
    EXPECT_NEAR(std::abs(Complex(table->real[2 * n + p], table->imag[2 * n + p])), 1.0,
                kFloatRelative);
    EXPECT_EQ(table->real[5 * n + p], 1.0f);  // unmeasured
    EXPECT_EQ(table->imag[5 * n + p], 0.0f);
    for (int j : {2, 10, 15}) {
      const Complex got(moments.real_plane(j)[p], moments.imag_plane(j)[p]);
      EXPECT_LT(std::abs(got - std::abs(gain[2][p]) * truth[j][p]),
                kFloatRelative * 2.0 * std::abs(truth[0][p]) * std::abs(gain[2][p]));
    }
  }
  // Another number of steps or another set is another calibration.
  ScheduleOptions other = kinect;
  other.buckets = 4;
  EXPECT_THAT(CheckCalibrationMatches(*table, other, geometry),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("calibration with 3-step sampling, capture with 4-step")));
  other = kinect;
  other.harmonics = {15, 2, 11};
  EXPECT_THAT(CheckCalibrationMatches(*table, other, geometry),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("calibration harmonics 2, 10, 15, capture harmonics 2, 11, 15")));
  other.harmonics = {15, 2, 10};  // the same set in another capture order
  EXPECT_THAT(CheckCalibrationMatches(*table, other, geometry), IsOk());
  // A depth camera has no moments to correct.
  ScheduleOptions depth;
  depth.sampling = SamplingScheme::kDepth;
  depth.max_depth_m = 5.0;
  EXPECT_THAT(CheckCalibrationMatches(*table, depth, geometry),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("the source delivers depth, not modulated captures: a "
                                 "calibration table")));
}

TEST(Calibration, UnusablePixelsGetNaNFactorsAndInvalidateMoments) {
  const ImageGeometry geometry{4, 2};
  const int64_t n = geometry.pixel_count();
  std::mt19937_64 rng(24);
  const auto gain = RandomGains(n, 2, rng);
  MomentImage dirac = MeasureDirac(geometry, gain, 0.0, rng);
  dirac.valid.assign(static_cast<size_t>(n), 1);
  dirac.valid[1] = 0;             // marked invalid (e.g. saturated)
  dirac.real_plane(0)[2] = 0.0f;  // no light
  dirac.real_plane(0)[3] = 0.5f;  // below min_signal
  dirac.imag_plane(2)[4] = std::nanf("");
  dirac.real_plane(1)[5] = 0.0f;  // a harmonic that measured nothing
  dirac.imag_plane(1)[5] = 0.0f;
  ScheduleOptions schedule = Schedule(ZerothScheme::kUnmodulatedPair, 2);
  absl::StatusOr<CalibrationTable> table = EstimateCalibration(dirac, schedule, 1, 1.0);
  ASSERT_THAT(table.status(), IsOk());
  for (int64_t p = 0; p < n; ++p) {
    const bool unusable = p >= 1 && p <= 5;
    EXPECT_EQ(table->valid[p], unusable ? 0 : 1) << p;
    EXPECT_EQ(std::isnan(table->real[2 * n + p]), unusable) << p;
  }
  MomentImage moments = FromComplex(geometry, SceneMoments(n, 2, rng));
  ASSERT_THAT(ApplyCalibration(*table, &moments), IsOk());
  for (int64_t p = 0; p < n; ++p) {
    const bool unusable = p >= 1 && p <= 5;
    EXPECT_EQ(moments.valid[p], unusable ? 0 : 1) << p;
    EXPECT_EQ(std::isnan(moments.real_plane(1)[p]), unusable) << p;
  }
}

class CalibrationMatchTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::mt19937_64 rng(25);
    const auto gain = RandomGains(geometry_.pixel_count(), 3, rng);
    absl::StatusOr<CalibrationTable> table =
        EstimateCalibration(MeasureDirac(geometry_, gain, 0.0, rng), Schedule(), 8);
    ASSERT_THAT(table.status(), IsOk());
    table_ = *std::move(table);
  }
  void ExpectMismatch(const ScheduleOptions& capture, ImageGeometry geometry,
                      absl::string_view text) {
    EXPECT_THAT(CheckCalibrationMatches(table_, capture, geometry),
                StatusIs(absl::StatusCode::kFailedPrecondition, HasSubstr(text)));
  }
  const ImageGeometry geometry_{4, 3};
  CalibrationTable table_;
};

TEST_F(CalibrationMatchTest, MatchingScheduleIsAcceptedWhateverItsTakes) {
  ScheduleOptions capture = Schedule();
  capture.takes = 7;
  EXPECT_THAT(CheckCalibrationMatches(table_, capture, geometry_), IsOk());
}

TEST_F(CalibrationMatchTest, MismatchesNameBothValues) {
  ExpectMismatch(Schedule(), {5, 3}, "calibration is for 4x3 pixels, the capture has 5x3");
  ScheduleOptions capture = Schedule();
  capture.base_frequency_hz = 20e6;
  ExpectMismatch(capture, geometry_, "calibration f = 23 MHz, capture f = 20 MHz");
  ExpectMismatch(Schedule(ZerothScheme::kUnmodulatedPair, 4), geometry_,
                 "calibration m = 3, capture m = 4");
  capture = Schedule();
  capture.sampling = SamplingScheme::kFourBucket;
  ExpectMismatch(capture, geometry_,
                 "calibration sampling arccos (n_phi = 8), capture sampling four-bucket");
  capture = Schedule();
  capture.phase_steps = 4;
  ExpectMismatch(capture, geometry_, "capture sampling arccos (n_phi = 4)");
  ExpectMismatch(Schedule(ZerothScheme::kLowFrequencyProxy), geometry_,
                 "calibration zeroth moment pair, capture zeroth moment proxy at 0.9 MHz");
}

TEST_F(CalibrationMatchTest, ApplyRefusesOtherGeometryOrOrder) {
  MomentImage other_size(ImageGeometry{3, 4}, 3);
  EXPECT_THAT(ApplyCalibration(table_, &other_size),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("calibration is for 4x3 pixels, the moments have 3x4")));
  MomentImage other_order(geometry_, 2);
  EXPECT_THAT(ApplyCalibration(table_, &other_order),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("calibration m = 3, moments m = 2")));
}

TEST_F(CalibrationMatchTest, ValidateNamesTheBrokenField) {
  CalibrationTable broken = table_;
  broken.real.pop_back();
  EXPECT_THAT(broken.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                          HasSubstr("calibration planes hold 47 real")));
  broken = table_;
  broken.valid.clear();
  EXPECT_THAT(broken.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("valid plane holds 0")));
  broken = table_;
  broken.order = 4;
  EXPECT_THAT(broken.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("calibration order m = 4")));
  broken = table_;
  broken.base_frequency_hz = 20e6;
  EXPECT_THAT(broken.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                          HasSubstr("calibration base_frequency_hz = 2e+07")));
  broken = table_;
  broken.takes_averaged = 0;
  EXPECT_THAT(broken.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("takes_averaged = 0")));
  EXPECT_THAT(CheckCalibrationMatches(broken, Schedule(), geometry_),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("takes_averaged = 0")));
}

TEST(Calibration, EstimateRefusesBadArguments) {
  MomentImage dirac(ImageGeometry{2, 2}, 3);
  EXPECT_THAT(EstimateCalibration(dirac, Schedule(ZerothScheme::kUnmodulatedPair, 2), 1).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("schedule order = 2")));
  EXPECT_THAT(EstimateCalibration(dirac, Schedule(), 0).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("takes_averaged = 0")));
  EXPECT_THAT(EstimateCalibration(dirac, Schedule(), 1, -1.0).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("min_signal = -1")));
}

}  // namespace
}  // namespace transient
