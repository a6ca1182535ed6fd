// The "sim:<scene>?key=value" URI: defaults, every key, and the errors that name what was wrong.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "tests/support/status_matchers.h"
#include "transient/drivers/simulator.h"

namespace transient {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

TEST(SimulatorUri, SceneAloneGivesTheDocumentedDefaults) {
  const absl::StatusOr<SimulatorOptions> o = ParseSimulatorUri("sim:mirrors");
  ASSERT_THAT(o.status(), IsOk());
  EXPECT_EQ(o->scene, "mirrors");
  EXPECT_EQ(o->schedule.base_frequency_hz, 23e6);
  EXPECT_EQ(o->schedule.order, 3);
  EXPECT_EQ(o->schedule.sampling, SamplingScheme::kArccos);
  EXPECT_EQ(o->schedule.phase_steps, 8);
  EXPECT_EQ(o->schedule.zeroth, ZerothScheme::kUnmodulatedPair);
  EXPECT_EQ(o->schedule.proxy_frequency_hz, 900e3);
  EXPECT_EQ(o->schedule.exposure_s, 1.92e-3);
  EXPECT_EQ(o->schedule.takes, 1);
  EXPECT_EQ(o->width, 163);
  EXPECT_EQ(o->height, 120);
  EXPECT_EQ(o->waveform, Waveform::kSquare);
  EXPECT_EQ(o->duty, 0.5);
  EXPECT_EQ(o->gain_error, 0.05);
  EXPECT_EQ(o->delay_error_ns, 0.3);
  EXPECT_EQ(o->adc_bits, 12);
  EXPECT_EQ(o->noise, NoiseModel::kPhysical);
  EXPECT_EQ(o->snr, 70.0);
  EXPECT_EQ(o->outliers, 0.0);
  EXPECT_EQ(o->pace, Pace::kRealtime);
  EXPECT_EQ(o->frames, 0);
}

TEST(SimulatorUri, KeyTableDefaultsParseToTheDefaultOptions) {
  std::string uri = "sim:mirrors?";
  for (const SourceKey& key : SimulatorKeys()) {
    uri += std::string(key.name) + "=" + std::string(key.default_value) + "&";
  }
  const absl::StatusOr<SimulatorOptions> o = ParseSimulatorUri(uri);
  ASSERT_THAT(o.status(), IsOk()) << uri;
  EXPECT_EQ(FormatSimulatorUri(*o), "sim:mirrors");
}

TEST(SimulatorUri, EveryKeyIsParsed) {
  const absl::StatusOr<SimulatorOptions> o = ParseSimulatorUri(
      "sim:sparse?f=20e6&m=4&scheme=harmonic-cancellation&nphi=3&zeroth=proxy&proxy_f=1e6&"
      "exposure=1e-3&takes=2&width=64&height=48&camera_seed=7&waveform=triangle&duty=0.3&"
      "gain_error=0.1&delay_ns=-2&delay_error_ns=0.5&ambient=2e5&brightness=1e7&full_well=9000&"
      "read_noise=5&adc_bits=14&noise=gaussian&snr=30&outliers=0.07&seed=9&readout=2e-3&"
      "pace=fast&frames=5&k=4&unplug_every=30&unplug_for=2.5");
  ASSERT_THAT(o.status(), IsOk());
  EXPECT_EQ(o->scene, "sparse");
  EXPECT_EQ(o->schedule.base_frequency_hz, 20e6);
  EXPECT_EQ(o->schedule.order, 4);
  EXPECT_EQ(o->schedule.sampling, SamplingScheme::kHarmonicCancellation);
  EXPECT_EQ(o->schedule.phase_steps, 3);
  EXPECT_EQ(o->schedule.zeroth, ZerothScheme::kLowFrequencyProxy);
  EXPECT_EQ(o->schedule.proxy_frequency_hz, 1e6);
  EXPECT_EQ(o->schedule.exposure_s, 1e-3);
  EXPECT_EQ(o->schedule.takes, 2);
  EXPECT_EQ(o->width, 64);
  EXPECT_EQ(o->height, 48);
  EXPECT_EQ(o->camera_seed, 7u);
  EXPECT_EQ(o->waveform, Waveform::kTriangle);
  EXPECT_EQ(o->duty, 0.3);
  EXPECT_EQ(o->gain_error, 0.1);
  EXPECT_EQ(o->delay_ns, -2.0);
  EXPECT_EQ(o->delay_error_ns, 0.5);
  EXPECT_EQ(o->ambient, 2e5);
  EXPECT_EQ(o->brightness, 1e7);
  EXPECT_EQ(o->full_well, 9000.0);
  EXPECT_EQ(o->read_noise, 5.0);
  EXPECT_EQ(o->adc_bits, 14);
  EXPECT_EQ(o->noise, NoiseModel::kGaussian);
  EXPECT_EQ(o->snr, 30.0);
  EXPECT_EQ(o->outliers, 0.07);
  EXPECT_EQ(o->seed, 9u);
  EXPECT_EQ(o->readout_s, 2e-3);
  EXPECT_EQ(o->pace, Pace::kFast);
  EXPECT_EQ(o->frames, 5);
  EXPECT_EQ(o->sparse_k, 4);
  EXPECT_EQ(o->unplug_every_s, 30.0);
  EXPECT_EQ(o->unplug_for_s, 2.5);
  // And back: the formatted URI parses to the same options.
  const absl::StatusOr<SimulatorOptions> again = ParseSimulatorUri(FormatSimulatorUri(*o));
  ASSERT_THAT(again.status(), IsOk());
  EXPECT_EQ(FormatSimulatorUri(*again), FormatSimulatorUri(*o));
  EXPECT_EQ(again->outliers, 0.07);
  EXPECT_EQ(again->schedule.sampling, SamplingScheme::kHarmonicCancellation);
}

// camera=kinect2 stands for the Kinect v2's keys; the other keys change it, in any order.
TEST(SimulatorUri, TheKinect2CameraIsAPresetThatTheOtherKeysChange) {
  const absl::StatusOr<SimulatorOptions> o =
      ParseSimulatorUri("sim:corner?width=128&camera=kinect2&height=96&pace=fast");
  ASSERT_THAT(o.status(), IsOk());
  EXPECT_EQ(o->camera, "kinect2");
  EXPECT_EQ(o->width, 128);
  EXPECT_EQ(o->height, 96);
  EXPECT_EQ(o->schedule.base_frequency_hz, 8e6);
  EXPECT_EQ(o->schedule.harmonics, (std::vector<int>{10, 2, 15}));
  EXPECT_EQ(o->schedule.order, 15);
  EXPECT_EQ(o->schedule.buckets, 3);
  EXPECT_EQ(o->schedule.zeroth, ZerothScheme::kEstimated);
  EXPECT_EQ(o->adc, Adc::kKinect2);
  EXPECT_EQ(o->waveform, Waveform::kSinusoid);
  EXPECT_NEAR(9 * o->frame_period_s(), 33.25e-3, 1e-12);  // 266 footer ticks of 125 us
  EXPECT_EQ(FormatSimulatorUri(*o), "sim:corner?camera=kinect2&width=128&height=96&pace=fast");
  const absl::StatusOr<SimulatorOptions> full = ParseSimulatorUri("sim:corner?camera=kinect2");
  ASSERT_THAT(full.status(), IsOk());
  EXPECT_EQ(full->width, 512);
  EXPECT_EQ(full->height, 424);
  // Back to 1..m on the Kinect's camera: formatted as harmonics=all, which parses again (the
  // daemon's calibration and takes rewrite the URI this way).
  absl::StatusOr<SimulatorOptions> all =
      ParseSimulatorUri("sim:corner?camera=kinect2&harmonics=all&m=3&f=20e6");
  ASSERT_THAT(all.status(), IsOk());
  EXPECT_TRUE(all->schedule.harmonics.empty());
  EXPECT_THAT(FormatSimulatorUri(*all), HasSubstr("harmonics=all"));
  ASSERT_THAT(ParseSimulatorUri(FormatSimulatorUri(*all)).status(), IsOk());
  EXPECT_THAT(ParseSimulatorUri("sim:corner?camera=kinect3").status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("camera = 'kinect3' is not accepted; expected generic or kinect2")));
}

TEST(SimulatorUri, HarmonicsSetTheOrderAndBucketsTheSteps) {
  absl::StatusOr<SimulatorOptions> o =
      ParseSimulatorUri("sim:mirrors?harmonics=4,1&buckets=5&f=10e6");
  ASSERT_THAT(o.status(), IsOk());
  EXPECT_EQ(o->schedule.harmonics, (std::vector<int>{4, 1}));
  EXPECT_EQ(o->schedule.order, 4);
  EXPECT_EQ(o->schedule.buckets, 5);
  EXPECT_EQ(FormatSimulatorUri(*o), "sim:mirrors?f=10000000&harmonics=4,1&buckets=5");
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?harmonics=4,1&m=3").status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("key m: order = 3. Violated constraint: order = max(harmonics)")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?harmonics=4,x").status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("sim: key harmonics: harmonic list '4,x': 'x' is not an integer")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?buckets=2").status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("key buckets: buckets = 2. Violated constraint: 3 <= buckets")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?adc=log").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("adc = 'log'")));
}

TEST(SimulatorUri, EveryScenesIsAccepted) {
  for (const SimulatorScene& scene : SimulatorScenes()) {
    EXPECT_THAT(ParseSimulatorUri("sim:" + std::string(scene.name)).status(), IsOk());
    EXPECT_FALSE(scene.description.empty());
  }
}

TEST(SimulatorUri, UnknownSceneIsRefusedWithTheAcceptedOnes) {
  EXPECT_THAT(ParseSimulatorUri("sim:kitchen?m=3").status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("unknown scene 'kitchen'; expected one of mirrors, corner")));
  EXPECT_THAT(ParseSimulatorUri("replay:x.h5").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("not a simulator URI")));
}

TEST(SimulatorUri, UnknownKeyIsRefusedWithTheAcceptedKeys) {
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?fps=30").status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("unknown key 'fps'; accepted keys: camera, f, m, harmonics")));
}

TEST(SimulatorUri, MalformedValuesNameTheKey) {
  using absl::StatusCode::kInvalidArgument;
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?f=fast").status(),
              StatusIs(kInvalidArgument, HasSubstr("key f = 'fast' is not a finite number")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?f=inf").status(),
              StatusIs(kInvalidArgument, HasSubstr("key f = 'inf' is not a finite number")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?width=1.5").status(),
              StatusIs(kInvalidArgument, HasSubstr("key width = '1.5' is not an integer")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?waveform=saw").status(),
              StatusIs(kInvalidArgument,
                       HasSubstr("waveform = 'saw' is not accepted; expected one of sinusoid, "
                                 "square, triangle")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?scheme=five-bucket").status(),
              StatusIs(kInvalidArgument, HasSubstr("key scheme: unknown sampling scheme")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?noise=pink").status(),
              StatusIs(kInvalidArgument, HasSubstr("noise = 'pink'")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?pace=slow").status(),
              StatusIs(kInvalidArgument, HasSubstr("pace = 'slow'")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?zeroth=guess").status(),
              StatusIs(kInvalidArgument, HasSubstr("key zeroth: unknown zeroth-moment scheme")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?m").status(),
              StatusIs(kInvalidArgument, HasSubstr("malformed parameter 'm'")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?m=").status(),
              StatusIs(kInvalidArgument, HasSubstr("malformed parameter 'm='")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?m=3&m=4").status(),
              StatusIs(kInvalidArgument, HasSubstr("key m given twice")));
}

TEST(SimulatorUri, OutOfRangeValuesNameTheViolatedConstraint) {
  using absl::StatusCode::kInvalidArgument;
  EXPECT_THAT(
      ParseSimulatorUri("sim:mirrors?width=0").status(),
      StatusIs(kInvalidArgument, HasSubstr("width = 0. Violated constraint: 8 <= width <= 640")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?height=481").status(),
              StatusIs(kInvalidArgument, HasSubstr("8 <= height <= 480")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?duty=1").status(),
              StatusIs(kInvalidArgument, HasSubstr("duty = 1. Violated constraint: 0 < duty < 1")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?adc_bits=4").status(),
              StatusIs(kInvalidArgument, HasSubstr("adc_bits = 4")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?outliers=1.5").status(),
              StatusIs(kInvalidArgument, HasSubstr("0 <= outliers <= 1")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?snr=0").status(),
              StatusIs(kInvalidArgument, HasSubstr("snr = 0")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?frames=-1").status(),
              StatusIs(kInvalidArgument, HasSubstr("frames = -1")));
  EXPECT_THAT(ParseSimulatorUri("sim:sparse?k=9").status(),
              StatusIs(kInvalidArgument, HasSubstr("1 <= k <= 8")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?unplug_every=-1").status(),
              StatusIs(kInvalidArgument, HasSubstr("0 <= unplug_every")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?unplug_every=5").status(),
              StatusIs(kInvalidArgument, HasSubstr("unplug_for = 0. Violated constraint: 0 < "
                                                   "unplug_for < unplug_every")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?unplug_every=5&unplug_for=5").status(),
              StatusIs(kInvalidArgument, HasSubstr("0 < unplug_for < unplug_every")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?unplug_for=1").status(),
              StatusIs(kInvalidArgument, HasSubstr("unplug_for = 0 unless unplug_every > 0")));
}

TEST(SimulatorUri, ImpossibleSchedulesAreRefusedWithTheirKey) {
  using absl::StatusCode::kInvalidArgument;
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?m=0").status(),
              StatusIs(kInvalidArgument, HasSubstr("key m: order = 0. Violated constraint")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?nphi=65").status(),
              StatusIs(kInvalidArgument, HasSubstr("key nphi: phase_steps = 65")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?zeroth=proxy&proxy_f=30e6").status(),
              StatusIs(kInvalidArgument, HasSubstr("key proxy_f: proxy_frequency_hz = 3e+07")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?exposure=0").status(),
              StatusIs(kInvalidArgument, HasSubstr("key exposure: exposure_s = 0")));
  EXPECT_THAT(ParseSimulatorUri("sim:mirrors?f=100e6&m=8").status(),
              StatusIs(kInvalidArgument, HasSubstr("m*f = 8e+08 Hz <= 5e+08 Hz")));
}

TEST(SimulatorOptions, OpenValidatesTheOptions) {
  SimulatorOptions options;
  options.width = 7;
  EXPECT_THAT(OpenSimulator(options).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("width = 7")));
}

}  // namespace
}  // namespace transient
