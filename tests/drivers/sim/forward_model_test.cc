// The simulator's signal formation against closed-form moments: the sign convention shared
// with the demodulator (simulator.h), the zeroth moment, and prop. 8.3 of the thesis.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "absl/strings/str_cat.h"
#include "tests/drivers/sim/sim_test_util.h"
#include "transient/reconstruct/pisarenko.h"

namespace transient::sim::testing {
namespace {

// The ideal camera: s = cos, no fixed pattern, no noise, float output.
constexpr absl::string_view kIdeal =
    "waveform=sinusoid&noise=none&gain_error=0&delay_ns=0&delay_error_ns=0&adc_bits=0&"
    "pace=fast&width=40&height=30";
// Float32 pixels and the table interpolation of the effective modulation (< 3e-7 of the
// amplitude) leave about 1e-6 of c_0; the tolerance has a margin of ten.
constexpr double kIdealTolerance = 1e-5;

struct Error {
  double max = 0.0;  // max over pixels and j >= 1 of |c_j - truth| / c_0
  double rms = 0.0;
};

Error CompareWithTruth(const std::vector<std::vector<Complex>>& moments, const GroundTruth& truth) {
  Error error;
  double sum = 0.0;
  int n = 0;
  for (size_t j = 1; j < moments.size(); ++j) {
    for (size_t p = 0; p < moments[j].size(); ++p) {
      const double c0 = TrueMoment(truth, 0, p).real();
      if (c0 <= 0.0) continue;
      const double e = std::abs(moments[j][p] - TrueMoment(truth, j, p)) / c0;
      error.max = std::max(error.max, e);
      sum += e * e;
      ++n;
    }
  }
  error.rms = std::sqrt(sum / n);
  return error;
}

class IdealPhasors : public ::testing::TestWithParam<std::string> {};

TEST_P(IdealPhasors, FourBucketPhasorOverNominalGainIsTheTrueMoment) {
  for (const char* scheme : {"four-bucket", "arccos", "harmonic-cancellation"}) {
    auto source = OpenOrDie(absl::StrCat("sim:", GetParam(), "?", kIdeal, "&scheme=", scheme));
    ASSERT_NE(source, nullptr);
    ASSERT_TRUE(source->Start().ok());
    const auto moments = Demodulate(CaptureCycle(*source), source->schedule());
    const absl::StatusOr<GroundTruth> truth = source->GroundTruthAt(0.0);
    ASSERT_TRUE(truth.ok()) << truth.status();
    EXPECT_LT(CompareWithTruth(moments, *truth).max, kIdealTolerance) << scheme;
    int lit = 0;
    for (size_t p = 0; p < moments[0].size(); ++p) {
      const double c0 = TrueMoment(*truth, 0, p).real();
      lit += c0 > 0.0;
      EXPECT_NEAR(moments[0][p].real(), c0, kIdealTolerance * c0) << "pair, pixel " << p;
    }
    EXPECT_GT(lit, 0);
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, IdealPhasors,
                         ::testing::Values("mirrors", "corner", "sparse", "video", "calibration"));

TEST(IdealPhasors, GlobalDelayRotatesEveryHarmonicByItsPhase) {
  // A delay d multiplies c_j by exp(i*2*pi*j*f*d): the sign convention of the phase.
  const double delay_ns = 2.0, f = 23e6;
  auto source = OpenOrDie(absl::StrCat(
      "sim:sparse?waveform=sinusoid&noise=none&gain_error=0&delay_error_ns=0&adc_bits=0&pace=fast&"
      "width=40&height=30&delay_ns=",
      delay_ns));
  ASSERT_NE(source, nullptr);
  ASSERT_TRUE(source->Start().ok());
  const auto moments = Demodulate(CaptureCycle(*source), source->schedule());
  const GroundTruth truth = *source->GroundTruthAt(0.0);
  for (int j = 1; j <= 3; ++j) {
    const Complex rotation = std::polar(1.0, kTwoPi * j * f * delay_ns * 1e-9);
    for (size_t p = 0; p < moments[j].size(); p += 7) {
      const double c0 = TrueMoment(truth, 0, p).real();
      EXPECT_LT(std::abs(moments[j][p] - rotation * TrueMoment(truth, j, p)), kIdealTolerance * c0);
    }
  }
}

TEST(IdealPhasors, ProxyMagnitudeIsCloseToTheZerothMoment) {
  // At 900 kHz the returns of the scene (< 40 ns) spread over less than 0.23 rad, so the
  // magnitude of the proxy phasor is within 1 - cos(0.23 / 2) < 0.7 % of c_0.
  constexpr double kProxyTolerance = 7e-3;
  for (const char* scene : {"mirrors", "corner", "sparse"}) {
    auto source = OpenOrDie(absl::StrCat("sim:", scene, "?", kIdeal, "&zeroth=proxy"));
    ASSERT_NE(source, nullptr);
    ASSERT_TRUE(source->Start().ok());
    const auto moments = Demodulate(CaptureCycle(*source), source->schedule());
    const GroundTruth truth = *source->GroundTruthAt(0.0);
    for (size_t p = 0; p < moments[0].size(); ++p) {
      const double c0 = TrueMoment(truth, 0, p).real();
      EXPECT_NEAR(moments[0][p].real(), c0, kProxyTolerance * c0) << scene << " pixel " << p;
      EXPECT_LE(moments[0][p].real(), c0 * (1.0 + kIdealTolerance)) << "|C(nu)| <= C(0)";
    }
  }
}

// Demodulated and calibrated (against the calibration scene of the same camera) moments of the
// mirrors scene, compared with the truth.
Error CalibratedError(absl::string_view waveform, absl::string_view sampling,
                      bool calibrate = true) {
  const std::string settings =
      absl::StrCat("noise=none&adc_bits=0&pace=fast&width=40&height=30&", waveform, "&", sampling);
  auto calibration = OpenOrDie(absl::StrCat("sim:calibration?", settings));
  auto scene = OpenOrDie(absl::StrCat("sim:mirrors?", settings));
  if (calibration == nullptr || scene == nullptr) return {INFINITY, INFINITY};
  EXPECT_TRUE(calibration->Start().ok());
  EXPECT_TRUE(scene->Start().ok());
  const auto factors =
      CalibrationFactors(Demodulate(CaptureCycle(*calibration), calibration->schedule()));
  auto moments = Demodulate(CaptureCycle(*scene), scene->schedule());
  if (calibrate) ApplyFactors(factors, &moments);
  return CompareWithTruth(moments, *scene->GroundTruthAt(0.0));
}

class Proposition83 : public ::testing::TestWithParam<std::string> {};

TEST_P(Proposition83, ArccosSamplingErrorShrinksAsPhaseStepsGrow) {
  const double four_bucket = CalibratedError(GetParam(), "scheme=four-bucket").rms;
  double previous = INFINITY;
  for (int n : {1, 2, 4, 8, 16}) {
    const double error = CalibratedError(GetParam(), absl::StrCat("scheme=arccos&nphi=", n)).rms;
    EXPECT_LT(error, previous) << "n_phi = " << n;
    previous = error;
  }
  // Odd harmonics alias into four-bucket phasors; n_phi = 8 removes most of them.
  EXPECT_GT(four_bucket, 5.0 * CalibratedError(GetParam(), "scheme=arccos&nphi=8").rms);
  EXPECT_GT(four_bucket,
            2.0 * CalibratedError(GetParam(), "scheme=harmonic-cancellation&nphi=3").rms);
}

INSTANTIATE_TEST_SUITE_P(Waveforms, Proposition83,
                         ::testing::Values("waveform=triangle", "waveform=square&duty=0.25"),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           return info.param == "waveform=triangle" ? std::string("Triangle")
                                                                    : std::string("SquareDuty25");
                         });

TEST(Calibration, CalibrationSceneRemovesTheCameraErrorsOfAnotherScene) {
  // Default camera (square waveform, gain and delay errors) and arccos with n_phi = 8: what is
  // left after calibration is the residual harmonic aliasing of the split (measured 0.8 % of c_0
  // RMS, 2.5 % at worst), against errors of tens of percent without calibration.
  constexpr double kResidualRms = 1e-2, kResidualMax = 3e-2, kUncalibrated = 0.1;
  constexpr absl::string_view kCamera = "scheme=arccos&gain_error=0.05&delay_ns=1.5";
  const Error calibrated = CalibratedError("waveform=square", kCamera);
  EXPECT_LT(calibrated.rms, kResidualRms);
  EXPECT_LT(calibrated.max, kResidualMax);
  EXPECT_GT(CalibratedError("waveform=square", kCamera, /*calibrate=*/false).rms, kUncalibrated);
}

TEST(Calibration, PisarenkoResolvesTheThreeMirrorReturnsOfACalibratedCapture) {
  // Default camera, noise-free: after calibration the residual aliasing of arccos n_phi = 8
  // (< 3 % of c_0) moves the weakest return by up to 0.12 m (measured); half the smallest
  // separation of the returns (0.3 m) still attributes every estimate to its own return.
  constexpr double kRangeTolerance = 0.15;  // m
  const std::string settings = "noise=none&adc_bits=0&pace=fast&width=40&height=30";
  auto calibration = OpenOrDie(absl::StrCat("sim:calibration?", settings));
  auto scene = OpenOrDie(absl::StrCat("sim:mirrors?", settings));
  ASSERT_TRUE(calibration != nullptr && scene != nullptr);
  ASSERT_TRUE(calibration->Start().ok() && scene->Start().ok());
  auto moments = Demodulate(CaptureCycle(*scene), scene->schedule());
  ApplyFactors(CalibrationFactors(Demodulate(CaptureCycle(*calibration), calibration->schedule())),
               &moments);
  const GroundTruth truth = *scene->GroundTruthAt(0.0);
  const int64_t count = truth.geometry.pixel_count();
  double worst = 0.0;
  for (int64_t p = 0; p < count; ++p) {
    const Complex c[4] = {moments[0][p], moments[1][p], moments[2][p], moments[3][p]};
    PisarenkoEstimate estimate;
    ASSERT_TRUE(Pisarenko(c, &estimate));
    ASSERT_EQ(estimate.count, 3) << "pixel " << p;
    for (int r = 0; r < 3; ++r) {
      const double range = PhaseToRange(estimate.phase[r], 23e6);
      worst = std::max(worst, std::abs(range - truth.return_range_m[r * count + p]));
    }
  }
  EXPECT_LT(worst, kRangeTolerance);
}

}  // namespace
}  // namespace transient::sim::testing
