// The built-in AMCW camera simulator (DESIGN.md: every feature runs without hardware). A scene
// gives each pixel an impulse response; a two-tap pixel correlates it with the effective
// modulation of thesis §8.2.1 under the acquisition schedule of §8.3, adds the camera's
// fixed-pattern errors, shot and read noise, and digitizes. Open it as "sim:<scene>?key=value&..."
// through OpenSource, or with the typed API below.
//
// Conventions (a contract with the demodulator, see acquisition.h):
//  * A modulated raw exposure at frequency nu with bucket shift beta and sub-exposures
//    (theta_k, w_k) measures, above the black level and in sensor units,
//      M = gain_p * sum_k w_k * integral s(2*pi*nu*(tau + d_p) - beta - theta_k) dG_p(tau),
//    where G_p is the pixel's impulse response, d_p its modulation delay (delay_ns plus the
//    per-pixel error), gain_p its demodulation contrast (1 plus the per-pixel error) and s the
//    2*pi-periodic effective modulation, normalized so that s = cos for waveform=sinusoid.
//    Then the four-bucket phasor Z = (M(0) - M(pi))/2 + i*(M(pi/2) - M(3*pi/2))/2 equals
//    nominal_gain() * c_j for s = cos, gain 1 and no delay.
//  * The unmodulated pair (illumination on, off) differs by the total light of the pixel: the
//    pair's c_0. Per-pixel gain and delay errors act on modulated exposures only, so the
//    calibration of thesis §8.3.2 (per pixel and harmonic, k_0 = 1) removes them completely.
//  * Ground-truth moments are c_j = K * integral exp(i*2*pi*j*f*tau) dG_p(tau) with K the pair's
//    conversion to sensor units: what a calibrated capture reproduces, in the pair's units.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "transient/drivers/capture_source.h"
#include "transient/drivers/source_registry.h"
#include "transient/reconstruct/acquisition.h"

namespace transient {

// Shape of the illumination and sensor modulation (thesis §8.2.1). The effective modulation s
// is the periodic cross-correlation of the illumination (mean 1) and the differential sensor
// modulation 2r - 1 (r in [0, 1] is the share of light going to tap A).
enum class Waveform {
  kSinusoid,  // r = (1 + cos)/2 with short illumination pulses: s = cos, the ideal of §8.2.1
  kSquare,    // r a 50 % square, illumination a square of duty `duty`: s a trapezoid (a
              // triangle for duty 0.5), odd harmonics falling like 1/h^2
  kTriangle,  // r a triangle with short illumination pulses: s the triangle of thesis fig. 8.2
};

enum class NoiseModel {
  kPhysical,  // Poisson shot noise per tap (Gaussian approximation for means >= 20 e-) + read
  kGaussian,  // additive Gaussian on each raw frame, std = pixel's total light / snr
  kNone,      // noise-free (ADC quantization still applies unless adc_bits = 0)
};

enum class Pace {
  kRealtime,  // Next sleeps until each frame's due time (frame period = exposure + readout)
  kFast,      // frames as fast as they can be computed; timestamps stay simulated
};

// How the tap difference becomes a sample.
enum class Adc {
  kLinear,   // adc_bits bits above a mid-scale black level (or float electrons for adc_bits 0)
  kKinect2,  // the Kinect v2's signed 11-bit companded samples (drivers/src/kinect2), full well
             // at the largest magnitude (16,320), saturation 32767; the first and last column
             // are unreadable (NaN), as the camera's are
};

// "sinusoid", "square", "triangle"; "physical", "gaussian", "none"; "realtime", "fast";
// "linear", "kinect2".
absl::string_view AdcName(Adc adc);
absl::string_view WaveformName(Waveform waveform);
absl::string_view NoiseModelName(NoiseModel noise);
absl::string_view PaceName(Pace pace);

// Everything a simulated capture depends on. The URI key of each field is given in brackets.
struct SimulatorOptions {
  std::string scene = "mirrors";  // one of SimulatorScenes()
  // [camera] "generic", or "kinect2": the Kinect v2's sensor and fixed schedule (512x424,
  // harmonics 10, 2, 15 of 8 MHz with three 120-degree steps, c_0 not measured, 11-bit
  // companded samples with saturation and dead columns, nine correlation sub-frames per
  // 33.25 ms, a sinusoidal modulation), which the other keys then change. A preset of the keys
  // below, applied before them whatever their order in the URI.
  std::string camera = "generic";
  // [f m harmonics buckets scheme nphi zeroth proxy_f exposure takes]
  ScheduleOptions schedule;

  // Sensor.
  int width = 163;                        // [width] pixels, 8..640
  int height = 120;                       // [height] pixels, 8..480
  uint64_t camera_seed = 1;               // [camera_seed] fixed-pattern errors of this camera unit
  Waveform waveform = Waveform::kSquare;  // [waveform]
  double duty = 0.5;            // [duty] illumination duty cycle of the square waveform, (0, 1)
  double gain_error = 0.05;     // [gain_error] relative std of the per-pixel contrast
  double delay_ns = 1.5;        // [delay_ns] global modulation delay, ns
  double delay_error_ns = 0.3;  // [delay_error_ns] std of the per-pixel delay (half a column
                                // gradient, half random), ns
  double ambient = 1e5;         // [ambient] background light, electrons/s/pixel
  double brightness = 8e6;      // [brightness] electrons/s from a white diffuse surface lit
                                // head-on at 1 m
  double full_well = 40000.0;   // [full_well] electrons per tap
  double read_noise = 20.0;     // [read_noise] electrons per tap
  int adc_bits = 12;            // [adc_bits] 8..16, or 0 = float output in electrons
  Adc adc = Adc::kLinear;       // [adc]
  NoiseModel noise = NoiseModel::kPhysical;  // [noise]
  double snr = 70.0;                         // [snr] noise=gaussian only (thesis fig. 8.12)
  double outliers = 0.0;        // [outliers] probability of a synchronization-slip raw frame
  uint64_t seed = 1;            // [seed] scene randomness and noise
  double readout_s = 3.78e-3;   // [readout] s between two exposures (thesis fig. 8.11 timing)
  Pace pace = Pace::kRealtime;  // [pace]
  int64_t frames = 0;           // [frames] transient frames (cycles) until OutOfRange; 0 = endless
  // Fault injection, for the daemon's soak run and tests of a camera that is unplugged and
  // plugged in again (a real one cannot be in CI): the camera is gone for the last
  // `unplug_for_s` seconds of every `unplug_every_s` seconds since this process first opened a
  // simulator. Next and opening then fail with Unavailable, as a lost device does.
  double unplug_every_s = 0.0;  // [unplug_every] s; 0 = never
  double unplug_for_s = 0.0;    // [unplug_for] s, 0 < unplug_for < unplug_every

  // Scene parameters.
  int sparse_k = 3;  // [k] returns per pixel of the sparse scene, 1..8

  // Names the first violated constraint with its URI key, e.g.
  // "width = 0. Violated constraint: 8 <= width <= 640". Also checks the schedule and that the
  // highest modulation frequency m*f is one the simulated sensor supports.
  absl::Status Validate() const;

  double frame_period_s() const { return schedule.exposure_s + readout_s; }
};

// A scene of the simulator and what it shows.
struct SimulatorScene {
  absl::string_view name;
  absl::string_view description;
};
std::span<const SimulatorScene> SimulatorScenes();
// The URI keys with their defaults and units, for `transient sim --help` and the docs.
std::span<const SourceKey> SimulatorKeys();

// The highest modulation frequency the simulated sensor accepts.
inline constexpr double kSimulatorMaxFrequencyHz = 500e6;

// Parses "sim:<scene>?key=value&..." (keys in any order, each at most once) and validates the
// result. InvalidArgument naming the scene, key or value and what is accepted.
[[nodiscard]] absl::StatusOr<SimulatorOptions> ParseSimulatorUri(absl::string_view uri);
// The URI of `options`: the scene and every key whose value differs from the default, with
// round-trip precision. ParseSimulatorUri(FormatSimulatorUri(o)) gives o back.
std::string FormatSimulatorUri(const SimulatorOptions& options);

// The URI of `transient sim SCENE`: "sim:SCENE?pace=fast&frames=N" followed by `keys`
// ("key=value" each), checked by ParseSimulatorUri. InvalidArgument naming the scene, key or
// value when one is unknown, "--set '<key>': expected key=value" for a key without a value, and
// "--frames = N: expected >= 1".
[[nodiscard]] absl::StatusOr<std::string> SimulatorUri(absl::string_view scene, int64_t frames,
                                                       const std::vector<std::string>& keys);

// Opens a simulated camera: builds the scene, the camera's fixed pattern and (for static
// scenes) the noise-free exposures. InvalidArgument when `options` fails Validate().
[[nodiscard]] absl::StatusOr<std::unique_ptr<CaptureSource>> OpenSimulator(
    const SimulatorOptions& options);

}  // namespace transient
