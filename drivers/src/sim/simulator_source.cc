// The simulator as a CaptureSource: runs the schedule cycle after cycle over a scene, with the
// camera's fixed pattern and sensor noise, on a simulated clock.
#include <cmath>
#include <memory>
#include <numbers>
#include <string>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "fixed_pattern.h"
#include "forward_model.h"
#include "random.h"
#include "scene.h"
#include "sensor.h"
#include "transient/drivers/simulator.h"

namespace transient {
namespace {

// Horizontal field of view of the simulated lens, like the pmd CamBoard nano's optics narrowed
// so that the mirrors of the `mirrors` scene stay outside the view.
constexpr double kHorizontalFovRad = std::numbers::pi / 3.0;
// Gain jumps of outlier frames: clearly off, either way (thesis §8.5: "differ significantly").
constexpr double kJumpLow[2] = {0.6, 0.9}, kJumpHigh[2] = {1.1, 1.4};

CameraInfo MakeCamera(const SimulatorOptions& options) {
  CameraInfo camera;
  camera.geometry = {options.width, options.height};
  camera.intrinsics.fx = camera.intrinsics.fy =
      0.5 * options.width / std::tan(0.5 * kHorizontalFovRad);
  camera.intrinsics.cx = 0.5 * (options.width - 1);
  camera.intrinsics.cy = 0.5 * (options.height - 1);
  camera.model = absl::StrCat("transient simulator (pmd PhotonICs 19k-S3 like, ",
                              WaveformName(options.waveform), " modulation)");
  camera.frame_period_s = options.frame_period_s();
  return camera;
}

// When the process first opened a simulator: the clock of the unplug_every/unplug_for outages,
// shared by every source of the process so that a reopened one sees the same outages.
absl::Time UnplugEpoch() {
  static const absl::Time epoch = absl::Now();
  return epoch;
}

// Unavailable while the fault injection of `options` has the camera unplugged.
absl::Status UnpluggedStatus(const std::string& uri, const SimulatorOptions& options) {
  if (options.unplug_every_s <= 0.0) return absl::OkStatus();
  const double since = absl::ToDoubleSeconds(absl::Now() - UnplugEpoch());
  if (std::fmod(since, options.unplug_every_s) < options.unplug_every_s - options.unplug_for_s) {
    return absl::OkStatus();
  }
  return absl::UnavailableError(absl::StrCat(uri, ": the simulated camera is unplugged (",
                                             options.unplug_for_s, " s of every ",
                                             options.unplug_every_s, " s)"));
}

class SimulatorSource : public CaptureSource {
 public:
  SimulatorSource(std::string uri, const SimulatorOptions& options, AcquisitionSchedule schedule,
                  CameraInfo camera, std::unique_ptr<sim::Scene> scene)
      : uri_(std::move(uri)),
        options_(options),
        schedule_(std::move(schedule)),
        camera_(std::move(camera)),
        scene_(std::move(scene)),
        model_(options, schedule_, sim::MakeFixedPattern(options)),
        sensor_(options),
        cycle_period_s_(schedule_.raw_frames_per_frame() * options.frame_period_s()) {
    if (!scene_->dynamic()) Prepare(0);
  }

  const std::string& uri() const override { return uri_; }
  const CameraInfo& camera() const override { return camera_; }
  const AcquisitionSchedule& schedule() const override { return schedule_; }
  SourceCapabilities capabilities() const override {
    return {.min_frequency_hz = 0.0,
            .max_frequency_hz = kSimulatorMaxFrequencyHz,
            .arbitrary_phase_shift = true,
            .unmodulated_exposures = true,
            .min_exposure_s = 1e-6,
            .max_exposure_s = 10.0,
            .replay = false};
  }

  absl::Status Start() override {
    if (started_) return absl::FailedPreconditionError(absl::StrCat(uri_, " is already started"));
    started_ = true;
    // The next frame is due now; later ones every frame period after it.
    anchor_ = absl::Now() - absl::Seconds(next_sequence_ * options_.frame_period_s());
    return absl::OkStatus();
  }

  absl::Status Stop() override {
    started_ = false;
    return absl::OkStatus();
  }

  absl::Status Next(absl::Duration timeout, RawFrame* frame) override {
    if (!started_) {
      return absl::FailedPreconditionError(absl::StrCat(uri_, ": Next before Start"));
    }
    const int per_cycle = schedule_.raw_frames_per_frame();
    const uint64_t sequence = next_sequence_;
    const int64_t cycle = static_cast<int64_t>(sequence / per_cycle);
    if (options_.frames > 0 && cycle >= options_.frames) {
      return absl::OutOfRangeError(
          absl::StrCat(uri_, ": all ", options_.frames, " transient frames were delivered"));
    }
    if (options_.pace == Pace::kRealtime) {
      const absl::Time due = anchor_ + absl::Seconds(sequence * options_.frame_period_s());
      const absl::Duration wait = due - absl::Now();
      if (wait > timeout) {
        absl::SleepFor(timeout);
        return absl::DeadlineExceededError(
            absl::StrCat(uri_, ": no frame within ", absl::FormatDuration(timeout)));
      }
      if (wait > absl::ZeroDuration()) absl::SleepFor(wait);
    }
    if (absl::Status unplugged = UnpluggedStatus(uri_, options_); !unplugged.ok()) {
      return unplugged;
    }
    if (scene_->dynamic() && cycle != prepared_cycle_) Prepare(cycle);

    const int index = static_cast<int>(sequence % per_cycle);
    frame->config = schedule_.exposures()[index];
    frame->config.cycle = cycle;
    frame->config.sequence = sequence;
    frame->config.timestamp_s = sequence * options_.frame_period_s();
    frame->geometry = camera_.geometry;
    frame->saturation_level = sensor_.saturation_level();
    frame->pixels.resize(camera_.geometry.pixel_count());
    Render(index % schedule_.exposures_per_take(), sequence, frame->pixels.data());
    ++next_sequence_;
    return absl::OkStatus();
  }

  absl::StatusOr<GroundTruth> GroundTruthAt(double timestamp_s) const override {
    if (!std::isfinite(timestamp_s) || timestamp_s < 0.0) {
      return absl::InvalidArgumentError(
          absl::StrCat("timestamp_s = ", timestamp_s, ". Violated constraint: timestamp_s >= 0"));
    }
    sim::ReturnPlanes dynamic_returns;
    const sim::ReturnPlanes* returns = &returns_;
    if (scene_->dynamic()) {
      // The frames of a cycle all show the scene at the cycle's first timestamp.
      scene_->Render(std::floor(timestamp_s / cycle_period_s_) * cycle_period_s_, &dynamic_returns);
      returns = &dynamic_returns;
    }
    return MakeGroundTruth(*returns);
  }

 private:
  // Renders the scene at the start of `cycle` and its noise-free exposures.
  void Prepare(int64_t cycle) {
    scene_->Render(cycle * cycle_period_s_, &returns_);
    model_.Evaluate(returns_, &signals_);
    prepared_cycle_ = cycle;
  }

  // Exposure `e` of the take into `out`; an outlier frame (probability `outliers`) is a
  // synchronization slip: the sensor ran one to three quarter periods off the requested bucket
  // (it holds that bucket's values) and the light level jumped by a factor in [0.6, 0.9] or
  // [1.1, 1.4]; an unmodulated frame gets the jump only, and a dark frame fires the light.
  void Render(int e, uint64_t sequence, float* out) const {
    const ExposureConfig& config = schedule_.exposures()[e];
    sim::TapInput input;
    input.modulated = config.frequency_hz != 0.0;
    input.illuminated = config.illumination;
    int source = e;
    if (options_.outliers > 0.0) {
      sim::Random random({options_.seed, sim::kStreamOutlier, sequence});
      if (random.Uniform() < options_.outliers) {
        const double u = random.Uniform();
        input.light_gain = u < 0.5 ? kJumpLow[0] + 2.0 * u * (kJumpLow[1] - kJumpLow[0])
                                   : kJumpHigh[0] + (2.0 * u - 1.0) * (kJumpHigh[1] - kJumpHigh[0]);
        if (input.modulated) {
          // Buckets of one frequency are consecutive: 2*pi*k/N, k = 0..N-1.
          const int n = schedule_.options().buckets;
          const int bucket = BucketIndex(config.phase_shift_rad, n);
          const int slip = 1 + static_cast<int>(random.Uniform() * (n - 1));
          source = e - bucket + (bucket + slip) % n;
        } else if (!config.illumination) {
          input.illuminated = true;
          source = e - 1;  // the dark frame follows the lit one: the same light
        }
      }
    }
    input.differential = signals_.differential[source].data();
    input.light = signals_.light.data();
    const int width = camera_.geometry.width, height = camera_.geometry.height;
#pragma omp parallel for schedule(static) if (camera_.geometry.pixel_count() > 50000)
    for (int v = 0; v < height; ++v) {
      sensor_.ReadRow(input, int64_t{v} * width, width, sequence, v, out + int64_t{v} * width);
    }
  }

  GroundTruth MakeGroundTruth(const sim::ReturnPlanes& returns) const {
    const double scale = 1.0 / sensor_.electrons_per_unit();
    GroundTruth truth;
    truth.geometry = camera_.geometry;
    truth.max_returns = returns.max_returns;
    const int64_t count = camera_.geometry.pixel_count();
    const size_t planes = static_cast<size_t>(returns.max_returns) * count;
    truth.first_range_m.assign(count, NAN);
    truth.return_range_m.assign(planes, NAN);
    truth.return_amplitude.assign(planes, NAN);
    truth.return_spread_m.assign(planes, NAN);
    for (int r = 0; r < returns.max_returns; ++r) {
      for (int64_t p = 0; p < count; ++p) {
        const int64_t i = returns.index(r, p);
        if (returns.amplitude[i] == 0.0f) continue;
        truth.return_range_m[i] = static_cast<float>(0.5 * kSpeedOfLight * returns.tau_s[i]);
        truth.return_amplitude[i] =
            static_cast<float>(scale * returns.amplitude[i] * options_.schedule.exposure_s);
        double spread = 0.0;
        if (returns.continuous(i)) {
          const double sigma = returns.sigma_s[i], rate = returns.decay_rate[i];
          spread = 0.5 * kSpeedOfLight *
                   std::sqrt(sigma * sigma + (rate > 0.0 ? 1.0 / (rate * rate) : 0.0));
        }
        truth.return_spread_m[i] = static_cast<float>(spread);
        if (r == 0) truth.first_range_m[p] = truth.return_range_m[i];
      }
    }
    truth.moments = model_.TrueMoments(returns, scale);
    return truth;
  }

  std::string uri_;
  SimulatorOptions options_;
  AcquisitionSchedule schedule_;
  CameraInfo camera_;
  std::unique_ptr<sim::Scene> scene_;
  sim::ForwardModel model_;
  sim::Sensor sensor_;
  double cycle_period_s_;

  sim::ReturnPlanes returns_;
  sim::ExposureSignals signals_;
  int64_t prepared_cycle_ = -1;

  bool started_ = false;
  uint64_t next_sequence_ = 0;
  absl::Time anchor_;
};

absl::StatusOr<std::unique_ptr<CaptureSource>> Open(std::string uri,
                                                    const SimulatorOptions& options) {
  if (absl::Status status = options.Validate(); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("sim: ", status.message()));
  }
  absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(options.schedule);
  if (!schedule.ok()) return schedule.status();
  CameraInfo camera = MakeCamera(options);
  absl::StatusOr<std::unique_ptr<sim::Scene>> scene = sim::MakeScene(options, camera);
  if (!scene.ok()) return scene.status();
  UnplugEpoch();  // the first simulator of the process starts the outages' clock
  if (absl::Status unplugged = UnpluggedStatus(uri, options); !unplugged.ok()) return unplugged;
  return std::make_unique<SimulatorSource>(std::move(uri), options, *std::move(schedule),
                                           std::move(camera), *std::move(scene));
}

}  // namespace

absl::StatusOr<std::unique_ptr<CaptureSource>> OpenSimulator(const SimulatorOptions& options) {
  return Open(FormatSimulatorUri(options), options);
}

namespace internal {
namespace {

absl::StatusOr<std::unique_ptr<CaptureSource>> OpenSimulatorSource(absl::string_view uri) {
  absl::StatusOr<SimulatorOptions> options = ParseSimulatorUri(uri);
  if (!options.ok()) return options.status();
  return Open(std::string(uri), *options);
}

// The `calibration` scene with the same camera keys, as fast as possible and endless.
absl::StatusOr<std::string> SimulatorCalibrationSource(absl::string_view uri) {
  absl::StatusOr<SimulatorOptions> options = ParseSimulatorUri(uri);
  if (!options.ok()) return options.status();
  options->scene = "calibration";
  options->pace = Pace::kFast;
  options->frames = 0;
  return FormatSimulatorUri(*options);
}

absl::StatusOr<std::string> SimulatorWithTakes(absl::string_view uri, int takes) {
  absl::StatusOr<SimulatorOptions> options = ParseSimulatorUri(uri);
  if (!options.ok()) return options.status();
  options->schedule.takes = takes;
  if (absl::Status status = options->schedule.Validate(); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("takes: ", status.message()));
  }
  return FormatSimulatorUri(*options);
}

}  // namespace

extern const SourceScheme kSimulatorScheme;
const SourceScheme kSimulatorScheme = {
    .name = "sim",
    .syntax = "sim:<scene>?key=value&...",
    .description =
        "the built-in AMCW camera simulator; scenes mirrors, corner, sparse, video, calibration",
    .keys = SimulatorKeys(),
    .capabilities = {.ground_truth = true,
                     .pace = true,
                     .calibration_scene = true,
                     .adjustable_takes = true},
    .open = OpenSimulatorSource,
    .calibration_source = SimulatorCalibrationSource,
    .with_takes = SimulatorWithTakes,
};

}  // namespace internal
}  // namespace transient
