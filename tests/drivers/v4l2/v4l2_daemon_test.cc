// transientd on the emulated MLX75027 (emulated_tof_sensor.h), whose frames the simulator
// renders (simulated_phases.h): the range it serves against the scene's ground truth, its moments
// against the same scene through sim:, a recording that replays to the same moments bit for bit,
// and the faults as GetStats shows them. A real daemon in this process, real gRPC on loopback.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "tests/drivers/v4l2/emulated_tof_sensor.h"
#include "tests/drivers/v4l2/simulated_phases.h"
#include "tests/service/daemon_fixture.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "tests/support/subprocess.h"
#include "transient/client/decoded_image.h"
#include "transient/drivers/capture_source.h"
#include "transient/reconstruct/percentile.h"
#include "v4l2/frame_unpacker.h"

namespace transient::v4l2 {
namespace {

using ::transient::service::PipelineOptions;
using ::transient::service::testing::Daemon;
using ::transient::service::testing::ExpectSameAsLive;
using ::transient::service::testing::DataDirAt;
using ::transient::service::testing::RecordWhileStreaming;
using ::transient::service::testing::Request;
using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;
using testing::EmulatedNode;
using testing::EmulatedTofSensor;
using testing::SequenceFault;
using testing::SimulatedPhases;

// The scene without the camera errors a calibration would remove (the v4l2: source has no
// calibration scene; both daemons run uncalibrated; SimulatedPhases sets no delay), at the
// emulated board's 64 x 48.
constexpr char kDaemonScene[] = "mirrors?gain_error=0&delay_error_ns=0&waveform=sinusoid";
constexpr char kSchedule[] =
    "f=20e6&m=3&scheme=four-bucket&zeroth=estimated&exposure=500e-6&width=64&height=48&"
    "delay_ns=0";
constexpr char kV4l2[] =
    "v4l2:/dev/video0?profile=mlx7502x&width=64&height=48&f=20e6&m=3&exposure=500e-6";

class V4l2DaemonTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(EmulatedTofSensor::Available())
        << "run under LD_PRELOAD=libumockdev-preload.so.0 (ctest does)";
  }

  // `idle_ns`: the sensor's pause before each sequence (the emulated sensor's default: 20 ms).
  void AddSensor(SimulatedPhases& light, int64_t idle_ns = 20'000'000) {
    EmulatedNode node;
    node.idle_ns = idle_ns;
    node.formats = {{kFourccY12P, "12-bit Greyscale (MIPI Packed)"}};
    node.controls = testing::Mlx7502xControls();
    node.sensor = {64, 48};
    node.renderer = light.AsRenderer();
    node.realtime = true;  // a sensor's pace: a cycle of three sequences every 78 ms by default
    sensor_.AddNode(node);
  }

  EmulatedTofSensor sensor_;
};

// The frames with images among the next `count` messages of a stream of `products`.
std::vector<v1::Frame> Receive(Daemon& daemon, std::initializer_list<v1::Product> products,
                               int count) {
  grpc::ClientContext context;
  context.set_deadline(absl::ToChronoTime(absl::Now() + absl::Seconds(60)));
  auto reader = daemon.Stub()->StreamFrames(&context, Request(products));
  std::vector<v1::Frame> frames;
  v1::Frame frame;
  while (static_cast<int>(frames.size()) < count && reader->Read(&frame)) {
    if (frame.images_size() > 0) frames.push_back(frame);
  }
  context.TryCancel();
  (void)reader->Finish();
  EXPECT_EQ(static_cast<int>(frames.size()), count);
  return frames;
}

std::map<std::string, std::vector<float>> Decoded(const v1::Frame& frame) {
  absl::StatusOr<std::vector<client::DecodedImage>> images = client::DecodeFrame(frame);
  EXPECT_THAT(images.status(), IsOk());
  std::map<std::string, std::vector<float>> out;
  if (images.ok()) {
    for (client::DecodedImage& image : *images) out[image.name] = std::move(image.values);
  }
  return out;
}

// Median |range - first return| over the pixels with both, and the share of pixels with range.
std::pair<double, double> RangeError(const std::vector<float>& range,
                                     const std::vector<float>& truth) {
  std::vector<double> errors;
  for (size_t p = 0; p < range.size(); ++p) {
    if (std::isfinite(range[p]) && std::isfinite(truth[p])) {
      errors.push_back(std::abs(range[p] - truth[p]));
    }
  }
  if (errors.empty()) return {INFINITY, 0.0};
  return {Percentile(errors, 50.0), static_cast<double>(errors.size()) / range.size()};
}

TEST_F(V4l2DaemonTest, RangeFromTheEmulatedSensorMatchesTheTruthLikeTheSimulatorsDoes) {
  SimulatedPhases light(kDaemonScene, /*signed_output=*/true);
  AddSensor(light);
  const std::string sim_uri = absl::StrCat("sim:", kDaemonScene, "&", kSchedule);
  absl::StatusOr<std::unique_ptr<CaptureSource>> sim = OpenSource(sim_uri);
  ASSERT_THAT(sim.status(), IsOk());
  absl::StatusOr<GroundTruth> truth = (*sim)->GroundTruthAt(0.0);
  ASSERT_THAT(truth.status(), IsOk());

  std::pair<double, double> v4l2_error, sim_error;
  {
    Daemon daemon(kV4l2);
    const std::vector<v1::Frame> frames = Receive(daemon, {v1::RANGE}, 3);
    ASSERT_FALSE(frames.empty());
    v4l2_error = RangeError(Decoded(frames.back())["range"], truth->first_range_m);
  }
  {
    Daemon daemon(sim_uri);
    const std::vector<v1::Frame> frames = Receive(daemon, {v1::RANGE}, 3);
    ASSERT_FALSE(frames.empty());
    sim_error = RangeError(Decoded(frames.back())["range"], truth->first_range_m);
  }
  // One tolerance for both (measured: 2.2 cm through the emulated sensor, 2.4 cm through sim:;
  // 0.8 cm for both without noise, the multipath bias of m = 3), and the emulated sensor no
  // worse than the simulator by more than noise.
  constexpr double kTolerance = 0.04;  // m, median
  EXPECT_LT(sim_error.first, kTolerance);
  EXPECT_LT(v4l2_error.first, kTolerance) << "the simulator's own: " << sim_error.first << " m";
  EXPECT_LT(v4l2_error.first, 1.5 * sim_error.first);
  EXPECT_GT(v4l2_error.second, 0.9) << "share of pixels with a range";
  RecordProperty("v4l2_median_range_error_m", absl::StrCat(v4l2_error.first));
  RecordProperty("sim_median_range_error_m", absl::StrCat(sim_error.first));
}

TEST_F(V4l2DaemonTest, MomentStateIsTheOneTheSameSceneGivesThroughSim) {
  // Noise-free, so that "within noise" is a bound on arithmetic: the emulated sensor renders
  // each harmonic with a camera at j*f, the sim: daemon all of them with one camera at f.
  const std::string scene = absl::StrCat(kDaemonScene, "&noise=none");
  SimulatedPhases light(scene, /*signed_output=*/true);
  AddSensor(light);
  std::map<std::string, std::vector<float>> from_v4l2, from_sim;
  {
    Daemon daemon(kV4l2);
    from_v4l2 = Decoded(Receive(daemon, {v1::MOMENT_STATE}, 2).back());
  }
  {
    Daemon daemon(absl::StrCat("sim:", scene, "&", kSchedule));
    from_sim = Decoded(Receive(daemon, {v1::MOMENT_STATE}, 2).back());
  }
  ASSERT_FALSE(from_sim.empty());
  ASSERT_EQ(from_v4l2.size(), from_sim.size());
  for (const auto& [name, expected] : from_sim) {
    const std::vector<float>& got = from_v4l2[name];
    ASSERT_EQ(got.size(), expected.size()) << name;
    float scale = 0;
    for (float v : expected) scale = std::max(scale, std::abs(v));
    int compared = 0;
    double largest = 0.0;
    for (size_t p = 0; p < got.size(); ++p) {
      if (!std::isfinite(expected[p])) {
        EXPECT_FALSE(std::isfinite(got[p])) << name << " pixel " << p;
        continue;
      }
      EXPECT_NEAR(got[p], expected[p], 2e-3 * scale) << name << " pixel " << p;
      largest = std::max(largest, static_cast<double>(std::abs(got[p] - expected[p])) / scale);
      ++compared;
    }
    EXPECT_GT(compared, 0) << name;
    RecordProperty(absl::StrCat("largest_relative_difference_", name), absl::StrCat(largest));
  }
}

// Median range errors against the scene's truth, through the emulated sensor and through sim:.
struct SchemeErrors {
  double v4l2_m = 0, sim_m = 0;
};

// Square-wave modulation (the simulator's default), whose third harmonic four-bucket sampling
// aliases onto the first: harmonic cancellation built from captures at 45 deg steps (n_phi = 3)
// removes it as the simulator's own sub-exposures do.
TEST_F(V4l2DaemonTest, HarmonicCancellationFromCapturesMatchesTheSimulatorsOwn) {
  // Brighter than the default (8e6): each sub-exposure is quantized by the ADC on its own, and
  // at a third of 500 us the wall gave about 15 DN, whose rounding alone moved the moments 3 %.
  const std::string scene = "mirrors?gain_error=0&delay_error_ns=0&noise=none&brightness=6e7";
  absl::StatusOr<std::unique_ptr<CaptureSource>> truth_source =
      OpenSource(absl::StrCat("sim:", scene, "&", kSchedule));
  ASSERT_THAT(truth_source.status(), IsOk());
  absl::StatusOr<GroundTruth> truth = (*truth_source)->GroundTruthAt(0.0);
  ASSERT_THAT(truth.status(), IsOk());
  std::map<std::string, SchemeErrors> errors;
  std::map<std::string, std::vector<float>> hc_v4l2, hc_sim;
  std::vector<std::unique_ptr<SimulatedPhases>> lights;  // outlive the nodes that use them
  int index = 0;
  for (const std::string scheme : {"four-bucket", "harmonic-cancellation"}) {
    SCOPED_TRACE(scheme);
    // One emulated sensor per scheme, /dev/video0 and /dev/video1 (one testbed per process).
    lights.push_back(std::make_unique<SimulatedPhases>(scene, /*signed_output=*/true));
    EmulatedNode node;
    node.name = absl::StrCat("video", index);
    node.formats = {{kFourccY12P, "12-bit Greyscale (MIPI Packed)"}};
    node.controls = testing::Mlx7502xControls();
    node.sensor = {64, 48};
    node.renderer = lights.back()->AsRenderer();
    node.realtime = true;
    sensor_.AddNode(node);
    const std::string keys = scheme == "four-bucket" ? "" : "&nphi=3";
    std::string schedule = kSchedule;
    schedule.replace(schedule.find("four-bucket"), 11, scheme);
    std::string uri = kV4l2;
    uri.replace(uri.find("video0"), 6, node.name);
    ++index;
    {
      Daemon daemon(absl::StrCat(uri, "&scheme=", scheme, keys));
      const v1::Frame frame = Receive(daemon, {v1::RANGE, v1::MOMENT_STATE}, 2).back();
      std::map<std::string, std::vector<float>> images = Decoded(frame);
      errors[scheme].v4l2_m = RangeError(images["range"], truth->first_range_m).first;
      if (scheme != "four-bucket") hc_v4l2 = images;
    }
    {
      Daemon daemon(absl::StrCat("sim:", scene, "&", schedule, keys));
      const v1::Frame frame = Receive(daemon, {v1::RANGE, v1::MOMENT_STATE}, 2).back();
      std::map<std::string, std::vector<float>> images = Decoded(frame);
      errors[scheme].sim_m = RangeError(images["range"], truth->first_range_m).first;
      if (scheme != "four-bucket") hc_sim = images;
    }
    RecordProperty(absl::StrCat(scheme, "_v4l2_median_range_error_m"),
                   absl::StrCat(errors[scheme].v4l2_m));
    RecordProperty(absl::StrCat(scheme, "_sim_median_range_error_m"),
                   absl::StrCat(errors[scheme].sim_m));
  }
  // The moments measured from the combined captures are the simulator's own harmonic
  // cancellation, up to the quantization of three frames instead of one.
  ASSERT_FALSE(hc_sim.empty());
  for (const auto& [name, expected] : hc_sim) {
    if (name.rfind("c_", 0) != 0) continue;  // c_real/j, c_imag/j
    const std::vector<float>& got = hc_v4l2[name];
    ASSERT_EQ(got.size(), expected.size()) << name;
    float scale = 0;
    for (float v : expected) scale = std::max(scale, std::abs(v));
    double largest = 0;
    for (size_t p = 0; p < got.size(); ++p) {
      if (std::isfinite(expected[p]) && std::isfinite(got[p])) {
        largest = std::max(largest, static_cast<double>(std::abs(got[p] - expected[p])) / scale);
      }
    }
    EXPECT_LT(largest, 1e-2) << name;
    RecordProperty(absl::StrCat("hc_largest_relative_difference_", name), absl::StrCat(largest));
  }
  // And as close to the truth as the simulator's, for both schemes (measured: 24.3 cm for
  // four-bucket, whose aliased third harmonic bends the range, 2.2 cm for harmonic
  // cancellation, the same through both sources), the cancellation far closer.
  for (const auto& [scheme, e] : errors) {
    EXPECT_LT(e.v4l2_m, e.sim_m + 0.005) << scheme;
  }
  EXPECT_LT(errors["harmonic-cancellation"].v4l2_m, 0.25 * errors["four-bucket"].v4l2_m);
}

TEST_F(V4l2DaemonTest, ARecordingReplaysToTheSameMomentStateBitForBit) {
  SimulatedPhases light(kDaemonScene, /*signed_output=*/true);
  // A slower sensor (a cycle every 0.31 s): every live cycle must reach the stream to be
  // compared, and the daemon under the sanitizers on a loaded machine dropped some at 78 ms.
  AddSensor(light, /*idle_ns=*/100'000'000);
  ScratchDirectory dir;
  const std::string path = dir.File("mlx75027.h5");
  PipelineOptions live{.source_uri = kV4l2};
  live.config.video = false;  // it fills outliers from the previous frame, which a replay lacks
  live.data_dir = DataDirAt(dir);
  std::map<double, v1::Frame> live_frames;  // by capture time
  {
    Daemon daemon(live);
    EXPECT_EQ(RecordWhileStreaming(daemon, "mlx75027.h5", 4, &live_frames), 4u * 12u);
  }
  // The file holds the read-back values and the driver's timestamps and sequence numbers.
  {
    absl::StatusOr<std::unique_ptr<CaptureSource>> replay =
        OpenSource(absl::StrCat("replay:", path, "?pace=fast"));
    ASSERT_THAT(replay.status(), IsOk());
    EXPECT_EQ((*replay)->schedule().raw_frames_per_frame(), 12);
    ASSERT_THAT((*replay)->Start(), IsOk());
    RawFrame first, second;
    ASSERT_THAT((*replay)->Next(absl::Seconds(5), &first), IsOk());
    ASSERT_THAT((*replay)->Next(absl::Seconds(5), &second), IsOk());
    EXPECT_DOUBLE_EQ(first.config.frequency_hz, 20e6);
    EXPECT_EQ(second.config.sequence, first.config.sequence + 1);
    // The emulated sensor's clock: 1.5 ms between the frames of a sequence.
    EXPECT_NEAR(second.config.timestamp_s - first.config.timestamp_s, 1.5e-3, 1e-6);
  }
  PipelineOptions replay{.source_uri = absl::StrCat("replay:", path, "?pace=fast")};
  replay.config.video = false;
  Daemon daemon(replay, /*start=*/false);
  std::vector<v1::Frame> replayed;
  std::thread receiver([&] { replayed = Receive(daemon, {v1::MOMENT_STATE}, 4); });
  EXPECT_TRUE(daemon.WaitForSubscribers(1));
  daemon.pipeline().Start();
  receiver.join();
  const int compared = ExpectSameAsLive(replayed, live_frames);
  EXPECT_EQ(compared, 4);
}

// `transient record` from the emulated sensor, as a child process (umockdev's preload library
// comes with the environment and hands its ioctls to this process's emulated sensor): the file
// holds the read-back integration time, the frequencies, and the driver's sequence numbers and
// timestamps, gap included.
TEST_F(V4l2DaemonTest, TransientRecordKeepsTheReadBackValuesAndTheDriversNumbering) {
  SimulatedPhases light(kDaemonScene, /*signed_output=*/true);
  EmulatedNode node;
  node.formats = {{kFourccY12P, "12-bit Greyscale (MIPI Packed)"}};
  node.controls = testing::Mlx7502xControls();
  node.controls[5].step = 8;  // integration time: 500 us reads back as 501 us
  node.sensor = {64, 48};
  node.renderer = light.AsRenderer();
  sensor_.AddNode(node);
  // The stream's fifth sequence (harmonic 2 of cycle 1) loses its last frame: the source gives
  // it up when the watchdog (timeout_ms) passes, and takes it again.
  sensor_.InjectFault("video0", {.sequence = 4, .kind = SequenceFault::kLostFrame, .frame = 3});
  ScratchDirectory dir;
  const std::string path = dir.File("record.h5");
  const ::transient::testing::ProcessResult result = ::transient::testing::RunProcess(
      {TRANSIENT_BINARY, "record", "--source", absl::StrCat(kV4l2, "&timeout_ms=200"), "--out",
       path, "--frames", "2"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  absl::StatusOr<std::unique_ptr<CaptureSource>> replay =
      OpenSource(absl::StrCat("replay:", path, "?pace=fast"));
  ASSERT_THAT(replay.status(), IsOk());
  EXPECT_DOUBLE_EQ((*replay)->schedule().options().exposure_s, 501e-6);
  ASSERT_THAT((*replay)->Start(), IsOk());
  std::vector<RawFrame> frames(24);
  for (RawFrame& frame : frames) ASSERT_THAT((*replay)->Next(absl::Seconds(5), &frame), IsOk());
  for (size_t i = 1; i < frames.size(); ++i) {
    const ExposureConfig& c = frames[i].config;
    EXPECT_DOUBLE_EQ(c.exposure_s, 501e-6);
    EXPECT_DOUBLE_EQ(c.frequency_hz, static_cast<double>(i / 4 % 3 + 1) * 20e6);
    const uint64_t step = c.sequence - frames[i - 1].config.sequence;
    const double pause = c.timestamp_s - frames[i - 1].config.timestamp_s;
    if (i == 16) {
      // Across the dropped sequence: its three frames and the lost one.
      EXPECT_EQ(step, 5u) << i;
    } else {
      EXPECT_EQ(step, 1u) << i;
    }
    // 1.5 ms between the frames of a sequence, 21.5 ms across the sensor's idle time.
    EXPECT_NEAR(pause, i % 4 == 0 ? (i == 16 ? 2 * 21.5e-3 + 3 * 1.5e-3 : 21.5e-3) : 1.5e-3, 1e-6)
        << i;
  }
}

int64_t StatsCounter(const v1::Stats& stats, const std::string& name) {
  for (const v1::SourceCounter& c : stats.source_counters()) {
    if (c.name() == name) return c.value();
  }
  return -1;
}

TEST_F(V4l2DaemonTest, FaultsShowInGetStatsAndAnUnpluggedSensorIsReconnected) {
  SimulatedPhases light(kDaemonScene, /*signed_output=*/true);
  AddSensor(light);
  PipelineOptions options{.source_uri = kV4l2};
  Daemon daemon(options);
  ASSERT_TRUE(daemon.WaitForFirstFrame());
  const int64_t next = sensor_.SequencesStarted("video0") + 1;
  sensor_.InjectFault("video0", {.sequence = next, .kind = SequenceFault::kErrorFlag, .frame = 1});
  sensor_.InjectFault("video0", {.sequence = next + 2, .kind = SequenceFault::kShortFrame});
  EXPECT_TRUE(daemon.WaitFor([&] {
    const v1::Stats stats = daemon.Stats();
    return StatsCounter(stats, "sequences_dropped_error_flag") == 1 &&
           StatsCounter(stats, "sequences_dropped_wrong_size") == 1;
  })) << daemon.Stats().DebugString();
  // No cycle was refused: the broken sequences never reached the demodulator.
  EXPECT_EQ(daemon.Stats().cycles_refused(), 0u);

  sensor_.Unplug("video0");
  EXPECT_TRUE(daemon.WaitFor([&] { return daemon.Stats().state() == v1::RECONNECTING; }));
  sensor_.Replug("video0");
  const uint64_t published = daemon.Stats().frames_published();
  EXPECT_TRUE(daemon.WaitFor([&] {
    const v1::Stats stats = daemon.Stats();
    return stats.state() == v1::STREAMING && stats.frames_published() > published + 1;
  })) << daemon.Stats().DebugString();
  EXPECT_GE(daemon.Stats().source_reopens(), 1u);
}

}  // namespace
}  // namespace transient::v4l2
