// The simulator's options: validation, the "sim:<scene>?key=value" URI and the key tables that
// `transient sources`, the help of both programs and docs/measuring.md print.
#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "kinect2/kinect2_format.h"
#include "source_uri.h"
#include "transient/drivers/simulator.h"

namespace transient {
namespace {

constexpr SimulatorScene kScenes[] = {
    {"mirrors",
     "diffuse wall lit directly and via two side mirrors: three Dirac returns per pixel "
     "(thesis fig. 8.7)"},
    {"corner",
     "diffuse corner lit from beside the camera: a Dirac return plus a continuous "
     "interreflection (thesis fig. 8.13)"},
    {"sparse", "k random Dirac returns per pixel (key k), drawn from the seed"},
    {"video",
     "a person walking in front of a wall with a mirror path (thesis fig. 8.14); "
     "changes every capture cycle"},
    {"calibration",
     "light straight into the sensor: a Dirac at time of flight zero "
     "(thesis fig. 8.3)"},
};

constexpr SourceKey kKeys[] = {
    {"camera", "generic", "",
     "generic, or kinect2: the Kinect v2 (512x424, harmonics 10,2,15 of 8 MHz, 3 steps, 11-bit "
     "companded samples); the other keys change it"},
    {"f", "23e6", "Hz", "base modulation frequency; harmonic j is modulated at j*f"},
    {"m", "3", "", "number of harmonics m (moments c_0..c_m)"},
    {"harmonics", "all", "",
     "the harmonics measured, in capture order, e.g. 10,2,15 (sets m to the highest), or all: "
     "1..m; only range, depth and amplitude unless they are all of 1..m"},
    {"buckets", "4", "", "phase steps N per harmonic at 360/N degrees, 3..16"},
    {"scheme", "arccos", "", "four-bucket, arccos or harmonic-cancellation (thesis §8.3.1)"},
    {"nphi", "8", "", "phase steps n_phi of arccos / harmonic cancellation"},
    {"zeroth", "pair", "", "zeroth moment: pair (on - off), proxy (low frequency) or estimated"},
    {"proxy_f", "900e3", "Hz", "frequency of the zeroth-moment proxy"},
    {"exposure", "1.92e-3", "s", "exposure time of each raw frame"},
    {"takes", "1", "", "repetitions of all exposures per transient frame"},
    {"width", "163", "px", "sensor width, 8..640"},
    {"height", "120", "px", "sensor height, 8..480"},
    {"camera_seed", "1", "", "the camera unit: its per-pixel gain and delay errors"},
    {"waveform", "square", "", "sinusoid, square or triangle modulation"},
    {"duty", "0.5", "", "illumination duty cycle of the square waveform"},
    {"gain_error", "0.05", "", "relative std of the per-pixel demodulation contrast"},
    {"delay_ns", "1.5", "ns", "global modulation delay"},
    {"delay_error_ns", "0.3", "ns", "std of the per-pixel delay (column gradient + random)"},
    {"ambient", "1e5", "e-/s", "background light per pixel"},
    {"brightness", "8e6", "e-/s", "signal of a white diffuse surface lit head-on at 1 m"},
    {"full_well", "40000", "e-", "capacity of each tap"},
    {"read_noise", "20", "e-", "read noise of each tap"},
    {"adc_bits", "12", "", "ADC resolution 8..16; 0 = float output in electrons"},
    {"adc", "linear", "", "linear (adc_bits), or kinect2: 11-bit companded signed samples"},
    {"noise", "physical", "", "physical (shot + read), gaussian (std = signal/snr) or none"},
    {"snr", "70", "", "signal-to-noise ratio of noise=gaussian"},
    {"outliers", "0", "", "probability of an outlier raw frame (synchronization slip)"},
    {"seed", "1", "", "scene randomness and noise"},
    {"readout", "3.78e-3", "s", "time between exposures; frame period = exposure + readout"},
    {"pace", "realtime", "", "realtime (sleep until each frame is due) or fast"},
    {"frames", "0", "", "transient frames (cycles) before the end; 0 = endless"},
    {"k", "3", "", "returns per pixel of the sparse scene, 1..8"},
    {"unplug_every", "0", "s",
     "fault injection: the camera is unplugged for the last unplug_for s of every unplug_every "
     "s since the process first opened a simulator; 0 = never"},
    {"unplug_for", "0", "s", "how long each unplugging lasts, 0 < unplug_for < unplug_every"},
};

absl::Status Violated(absl::string_view key, double value, absl::string_view rule) {
  return absl::InvalidArgumentError(
      absl::StrCat(key, " = ", value, ". Violated constraint: ", rule));
}

bool InRange(double value, double lo, double hi) {
  return std::isfinite(value) && value >= lo && value <= hi;
}

// The URI key of each ScheduleOptions field, so that schedule errors name what the user typed.
constexpr std::pair<absl::string_view, absl::string_view> kScheduleFieldKeys[] = {
    {"base_frequency_hz", "f"}, {"order", "m"},
    {"phase_steps", "nphi"},    {"proxy_frequency_hz", "proxy_f"},
    {"buckets", "buckets"},     {"harmonics", "harmonics"},
    {"exposure_s", "exposure"}, {"takes", "takes"},
};

template <typename T>
absl::Status ParseEnum(absl::string_view key, absl::string_view text,
                       std::initializer_list<T> values, absl::string_view (*name)(T), T* out) {
  std::vector<std::string> names;
  for (T v : values) {
    if (text == name(v)) {
      *out = v;
      return absl::OkStatus();
    }
    names.emplace_back(name(v));
  }
  return absl::InvalidArgumentError(absl::StrCat("sim: key ", key, " = '", text,
                                                 "' is not accepted; expected one of ",
                                                 absl::StrJoin(names, ", ")));
}

absl::Status ParseDouble(absl::string_view key, absl::string_view text, double* out) {
  double value = 0.0;
  if (!absl::SimpleAtod(text, &value) || !std::isfinite(value)) {
    return absl::InvalidArgumentError(
        absl::StrCat("sim: key ", key, " = '", text, "' is not a finite number"));
  }
  *out = value;
  return absl::OkStatus();
}

template <typename Int>
absl::Status ParseInt(absl::string_view key, absl::string_view text, Int* out) {
  Int value = 0;
  if (!absl::SimpleAtoi(text, &value)) {
    return absl::InvalidArgumentError(
        absl::StrCat("sim: key ", key, " = '", text, "' is not an integer"));
  }
  *out = value;
  return absl::OkStatus();
}

using Setter = std::function<absl::Status(absl::string_view key, absl::string_view value,
                                          SimulatorOptions* o)>;

Setter Double(double SimulatorOptions::*field) {
  return [field](absl::string_view key, absl::string_view v, SimulatorOptions* o) {
    return ParseDouble(key, v, &(o->*field));
  };
}
Setter ScheduleDouble(double ScheduleOptions::*field) {
  return [field](absl::string_view key, absl::string_view v, SimulatorOptions* o) {
    return ParseDouble(key, v, &(o->schedule.*field));
  };
}
template <typename Int>
Setter Integer(Int SimulatorOptions::*field) {
  return [field](absl::string_view key, absl::string_view v, SimulatorOptions* o) {
    return ParseInt(key, v, &(o->*field));
  };
}
Setter ScheduleInt(int ScheduleOptions::*field) {
  return [field](absl::string_view key, absl::string_view v, SimulatorOptions* o) {
    return ParseInt(key, v, &(o->schedule.*field));
  };
}

const std::map<absl::string_view, Setter>& Setters() {
  static const auto* setters = new std::map<absl::string_view, Setter>{
      {"f", ScheduleDouble(&ScheduleOptions::base_frequency_hz)},
      {"m", ScheduleInt(&ScheduleOptions::order)},
      {"scheme",
       [](absl::string_view k, absl::string_view v, SimulatorOptions* o) {
         auto parsed = ParseSamplingScheme(v);
         if (!parsed.ok()) {
           return absl::InvalidArgumentError(
               absl::StrCat("sim: key ", k, ": ", parsed.status().message()));
         }
         o->schedule.sampling = *parsed;
         return absl::OkStatus();
       }},
      {"nphi", ScheduleInt(&ScheduleOptions::phase_steps)},
      {"buckets", ScheduleInt(&ScheduleOptions::buckets)},
      {"harmonics",
       [](absl::string_view k, absl::string_view v, SimulatorOptions* o) {
         if (v == "all") {  // 1..m
           o->schedule.harmonics.clear();
           return absl::OkStatus();
         }
         absl::StatusOr<std::vector<int>> parsed = ParseHarmonicList(v);
         if (!parsed.ok()) {
           return absl::InvalidArgumentError(
               absl::StrCat("sim: key ", k, ": ", parsed.status().message()));
         }
         o->schedule.harmonics = *std::move(parsed);
         int highest = 0;
         for (int j : o->schedule.harmonics) highest = std::max(highest, j);
         o->schedule.order = highest;  // m follows the set
         return absl::OkStatus();
       }},
      {"zeroth",
       [](absl::string_view k, absl::string_view v, SimulatorOptions* o) {
         auto parsed = ParseZerothScheme(v);
         if (!parsed.ok()) {
           return absl::InvalidArgumentError(
               absl::StrCat("sim: key ", k, ": ", parsed.status().message()));
         }
         o->schedule.zeroth = *parsed;
         return absl::OkStatus();
       }},
      {"proxy_f", ScheduleDouble(&ScheduleOptions::proxy_frequency_hz)},
      {"exposure", ScheduleDouble(&ScheduleOptions::exposure_s)},
      {"takes", ScheduleInt(&ScheduleOptions::takes)},
      {"width", Integer(&SimulatorOptions::width)},
      {"height", Integer(&SimulatorOptions::height)},
      {"camera_seed", Integer(&SimulatorOptions::camera_seed)},
      {"waveform",
       [](absl::string_view k, absl::string_view v, SimulatorOptions* o) {
         return ParseEnum(k, v, {Waveform::kSinusoid, Waveform::kSquare, Waveform::kTriangle},
                          &WaveformName, &o->waveform);
       }},
      {"duty", Double(&SimulatorOptions::duty)},
      {"gain_error", Double(&SimulatorOptions::gain_error)},
      {"delay_ns", Double(&SimulatorOptions::delay_ns)},
      {"delay_error_ns", Double(&SimulatorOptions::delay_error_ns)},
      {"ambient", Double(&SimulatorOptions::ambient)},
      {"brightness", Double(&SimulatorOptions::brightness)},
      {"full_well", Double(&SimulatorOptions::full_well)},
      {"read_noise", Double(&SimulatorOptions::read_noise)},
      {"adc_bits", Integer(&SimulatorOptions::adc_bits)},
      {"adc",
       [](absl::string_view k, absl::string_view v, SimulatorOptions* o) {
         return ParseEnum(k, v, {Adc::kLinear, Adc::kKinect2}, &AdcName, &o->adc);
       }},
      {"noise",
       [](absl::string_view k, absl::string_view v, SimulatorOptions* o) {
         return ParseEnum(k, v, {NoiseModel::kPhysical, NoiseModel::kGaussian, NoiseModel::kNone},
                          &NoiseModelName, &o->noise);
       }},
      {"snr", Double(&SimulatorOptions::snr)},
      {"outliers", Double(&SimulatorOptions::outliers)},
      {"seed", Integer(&SimulatorOptions::seed)},
      {"readout", Double(&SimulatorOptions::readout_s)},
      {"pace",
       [](absl::string_view k, absl::string_view v, SimulatorOptions* o) {
         return ParseEnum(k, v, {Pace::kRealtime, Pace::kFast}, &PaceName, &o->pace);
       }},
      {"frames", Integer(&SimulatorOptions::frames)},
      {"k", Integer(&SimulatorOptions::sparse_k)},
      {"unplug_every", Double(&SimulatorOptions::unplug_every_s)},
      {"unplug_for", Double(&SimulatorOptions::unplug_for_s)},
  };
  return *setters;
}

std::string SceneNames() {
  std::vector<absl::string_view> names;
  for (const SimulatorScene& scene : kScenes) names.push_back(scene.name);
  return absl::StrJoin(names, ", ");
}

std::string Number(double value) { return absl::StrFormat("%.17g", value); }

}  // namespace

absl::string_view AdcName(Adc adc) {
  switch (adc) {
    case Adc::kLinear:
      return "linear";
    case Adc::kKinect2:
      return "kinect2";
  }
  return "unknown";
}

namespace {

// The keys a camera stands for (SimulatorOptions::camera).
absl::Status ApplyCameraPreset(absl::string_view camera, SimulatorOptions* o) {
  if (camera == "generic") {
    o->camera = "generic";
    return absl::OkStatus();
  }
  if (camera != "kinect2") {
    return absl::InvalidArgumentError(
        absl::StrCat("sim: key camera = '", camera, "' is not accepted; expected generic or kinect2"));
  }
  o->camera = "kinect2";
  o->schedule = kinect2::Schedule();
  o->width = kinect2::kWidth;
  o->height = kinect2::kHeight;
  o->waveform = Waveform::kSinusoid;
  o->adc = Adc::kKinect2;
  // Nine correlation sub-frames in the camera's 33.25 ms frame (the tenth's slot shared out).
  o->readout_s = kinect2::kFramePeriodS / kinect2::kCorrelationSubFrames - o->schedule.exposure_s;
  return absl::OkStatus();
}

}  // namespace

absl::string_view WaveformName(Waveform waveform) {
  switch (waveform) {
    case Waveform::kSinusoid:
      return "sinusoid";
    case Waveform::kSquare:
      return "square";
    case Waveform::kTriangle:
      return "triangle";
  }
  return "unknown";
}

absl::string_view NoiseModelName(NoiseModel noise) {
  switch (noise) {
    case NoiseModel::kPhysical:
      return "physical";
    case NoiseModel::kGaussian:
      return "gaussian";
    case NoiseModel::kNone:
      return "none";
  }
  return "unknown";
}

absl::string_view PaceName(Pace pace) {
  switch (pace) {
    case Pace::kRealtime:
      return "realtime";
    case Pace::kFast:
      return "fast";
  }
  return "unknown";
}

std::span<const SimulatorScene> SimulatorScenes() { return kScenes; }
std::span<const SourceKey> SimulatorKeys() { return kKeys; }

absl::Status SimulatorOptions::Validate() const {
  bool known_scene = false;
  for (const SimulatorScene& s : kScenes) known_scene |= (s.name == scene);
  if (!known_scene) {
    return absl::InvalidArgumentError(
        absl::StrCat("unknown scene '", scene, "'; expected one of ", SceneNames()));
  }
  if (camera != "generic" && camera != "kinect2") {
    return absl::InvalidArgumentError(
        absl::StrCat("camera = '", camera, "'. Violated constraint: generic or kinect2"));
  }
  if (absl::Status status = schedule.Validate(); !status.ok()) {
    for (const auto& [field, key] : kScheduleFieldKeys) {
      if (absl::StartsWith(status.message(), absl::StrCat(field, " = "))) {
        return absl::InvalidArgumentError(absl::StrCat("key ", key, ": ", status.message()));
      }
    }
    return status;
  }
  const double highest_hz = schedule.order * schedule.base_frequency_hz;
  if (highest_hz > kSimulatorMaxFrequencyHz) {
    return absl::InvalidArgumentError(absl::StrCat(
        "f = ", schedule.base_frequency_hz, ". Violated constraint: m*f = ", highest_hz, " Hz <= ",
        kSimulatorMaxFrequencyHz, " Hz, the highest modulation frequency of the sensor"));
  }
  if (width < 8 || width > 640) return Violated("width", width, "8 <= width <= 640");
  if (height < 8 || height > 480) return Violated("height", height, "8 <= height <= 480");
  if (!InRange(duty, 0.0, 1.0) || duty == 0.0 || duty == 1.0) {
    return Violated("duty", duty, "0 < duty < 1");
  }
  if (!InRange(gain_error, 0.0, 0.3))
    return Violated("gain_error", gain_error, "0 <= gain_error <= 0.3");
  if (!InRange(delay_ns, -100.0, 100.0)) return Violated("delay_ns", delay_ns, "|delay_ns| <= 100");
  if (!InRange(delay_error_ns, 0.0, 10.0)) {
    return Violated("delay_error_ns", delay_error_ns, "0 <= delay_error_ns <= 10");
  }
  if (!InRange(ambient, 0.0, 1e12)) return Violated("ambient", ambient, "0 <= ambient <= 1e12");
  if (!InRange(brightness, 0.0, 1e13) || brightness == 0.0) {
    return Violated("brightness", brightness, "0 < brightness <= 1e13");
  }
  if (!InRange(full_well, 100.0, 1e8))
    return Violated("full_well", full_well, "100 <= full_well <= 1e8");
  if (!InRange(read_noise, 0.0, 1e4))
    return Violated("read_noise", read_noise, "0 <= read_noise <= 1e4");
  if (adc_bits != 0 && (adc_bits < 8 || adc_bits > 16)) {
    return Violated("adc_bits", adc_bits, "adc_bits = 0 or 8 <= adc_bits <= 16");
  }
  if (!InRange(snr, 0.0, 1e9) || snr == 0.0) return Violated("snr", snr, "0 < snr <= 1e9");
  if (!InRange(outliers, 0.0, 1.0)) return Violated("outliers", outliers, "0 <= outliers <= 1");
  if (!InRange(readout_s, 0.0, 10.0)) return Violated("readout", readout_s, "0 <= readout <= 10");
  if (frames < 0) return Violated("frames", static_cast<double>(frames), "frames >= 0");
  if (sparse_k < 1 || sparse_k > 8) return Violated("k", sparse_k, "1 <= k <= 8");
  if (!InRange(unplug_every_s, 0.0, 1e9)) {
    return Violated("unplug_every", unplug_every_s, "0 <= unplug_every <= 1e9");
  }
  if (unplug_every_s > 0.0 && !(unplug_for_s > 0.0 && unplug_for_s < unplug_every_s)) {
    return Violated("unplug_for", unplug_for_s, "0 < unplug_for < unplug_every");
  }
  if (unplug_every_s == 0.0 && unplug_for_s != 0.0) {
    return Violated("unplug_for", unplug_for_s, "unplug_for = 0 unless unplug_every > 0");
  }
  return absl::OkStatus();
}

absl::StatusOr<SimulatorOptions> ParseSimulatorUri(absl::string_view uri) {
  absl::StatusOr<internal::SourceUri> parsed = internal::ParseSourceUri(uri);
  if (!parsed.ok()) return parsed.status();
  if (parsed->scheme != "sim") {
    return absl::InvalidArgumentError(
        absl::StrCat("'", uri, "' is not a simulator URI; expected sim:<scene>?key=value&..."));
  }
  SimulatorOptions options;
  options.scene = parsed->target;
  bool known_scene = false;
  for (const SimulatorScene& s : kScenes) known_scene |= (s.name == options.scene);
  if (!known_scene) {
    return absl::InvalidArgumentError(
        absl::StrCat("sim: unknown scene '", options.scene, "'; expected one of ", SceneNames()));
  }
  for (const auto& [key, value] : parsed->keys) {
    if (key != "camera") continue;  // the preset first: the other keys change it
    if (absl::Status status = ApplyCameraPreset(value, &options); !status.ok()) return status;
  }
  for (const auto& [key, value] : parsed->keys) {
    if (key == "camera") continue;
    const auto setter = Setters().find(key);
    if (setter == Setters().end()) {
      return internal::UnknownKey("sim", key, kKeys);
    }
    if (absl::Status status = setter->second(key, value, &options); !status.ok()) return status;
  }
  if (absl::Status status = options.Validate(); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("sim: ", status.message()));
  }
  return options;
}

std::string FormatSimulatorUri(const SimulatorOptions& o) {
  SimulatorOptions d;  // the defaults of o's camera
  std::vector<std::string> parts;
  if (o.camera != d.camera) {
    (void)ApplyCameraPreset(o.camera, &d);
    parts.push_back(absl::StrCat("camera=", o.camera));
  }
  auto number = [&](absl::string_view key, double value, double fallback) {
    if (value != fallback) parts.push_back(absl::StrCat(key, "=", Number(value)));
  };
  auto integer = [&](absl::string_view key, int64_t value, int64_t fallback) {
    if (value != fallback) parts.push_back(absl::StrCat(key, "=", value));
  };
  auto name = [&](absl::string_view key, absl::string_view value, absl::string_view fallback) {
    if (value != fallback) parts.push_back(absl::StrCat(key, "=", value));
  };
  const ScheduleOptions& s = o.schedule;
  number("f", s.base_frequency_hz, d.schedule.base_frequency_hz);
  if (s.harmonics != d.schedule.harmonics) {
    parts.push_back(absl::StrCat(
        "harmonics=", s.harmonics.empty() ? "all" : FormatHarmonicList(s.harmonics)));
  }
  if (s.harmonics.empty()) integer("m", s.order, d.schedule.order);
  integer("buckets", s.buckets, d.schedule.buckets);
  name("scheme", SamplingSchemeName(s.sampling), SamplingSchemeName(d.schedule.sampling));
  integer("nphi", s.phase_steps, d.schedule.phase_steps);
  name("zeroth", ZerothSchemeName(s.zeroth), ZerothSchemeName(d.schedule.zeroth));
  number("proxy_f", s.proxy_frequency_hz, d.schedule.proxy_frequency_hz);
  number("exposure", s.exposure_s, d.schedule.exposure_s);
  integer("takes", s.takes, d.schedule.takes);
  integer("width", o.width, d.width);
  integer("height", o.height, d.height);
  if (o.camera_seed != d.camera_seed) parts.push_back(absl::StrCat("camera_seed=", o.camera_seed));
  name("waveform", WaveformName(o.waveform), WaveformName(d.waveform));
  number("duty", o.duty, d.duty);
  number("gain_error", o.gain_error, d.gain_error);
  number("delay_ns", o.delay_ns, d.delay_ns);
  number("delay_error_ns", o.delay_error_ns, d.delay_error_ns);
  number("ambient", o.ambient, d.ambient);
  number("brightness", o.brightness, d.brightness);
  number("full_well", o.full_well, d.full_well);
  number("read_noise", o.read_noise, d.read_noise);
  integer("adc_bits", o.adc_bits, d.adc_bits);
  name("adc", AdcName(o.adc), AdcName(d.adc));
  name("noise", NoiseModelName(o.noise), NoiseModelName(d.noise));
  number("snr", o.snr, d.snr);
  number("outliers", o.outliers, d.outliers);
  if (o.seed != d.seed) parts.push_back(absl::StrCat("seed=", o.seed));
  number("readout", o.readout_s, d.readout_s);
  name("pace", PaceName(o.pace), PaceName(d.pace));
  integer("frames", o.frames, d.frames);
  integer("k", o.sparse_k, d.sparse_k);
  number("unplug_every", o.unplug_every_s, d.unplug_every_s);
  number("unplug_for", o.unplug_for_s, d.unplug_for_s);
  std::string uri = absl::StrCat("sim:", o.scene);
  if (!parts.empty()) absl::StrAppend(&uri, "?", absl::StrJoin(parts, "&"));
  return uri;
}

absl::StatusOr<std::string> SimulatorUri(absl::string_view scene, int64_t frames,
                                         const std::vector<std::string>& keys) {
  if (frames < 1) {
    return absl::InvalidArgumentError(absl::StrCat("--frames = ", frames, ": expected >= 1"));
  }
  std::string uri = absl::StrCat("sim:", scene, "?pace=fast&frames=", frames);
  for (const std::string& key : keys) {
    if (!absl::StrContains(key, '=')) {
      return absl::InvalidArgumentError(
          absl::StrCat("--set '", key, "': expected key=value (see transient sim --help)"));
    }
    absl::StrAppend(&uri, "&", key);
  }
  absl::StatusOr<SimulatorOptions> options = ParseSimulatorUri(uri);
  if (!options.ok()) return options.status();
  return uri;
}

}  // namespace transient
