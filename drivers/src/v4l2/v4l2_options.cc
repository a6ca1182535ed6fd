// The keys of a `v4l2:` URI (v4l2_options.h).
#include "v4l2/v4l2_options.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "source_uri.h"
#include "transient/reconstruct/moments.h"
#include "transient/reconstruct/status_context.h"

namespace transient::v4l2 {
namespace {

constexpr SourceKey kV4l2Keys[] = {
    {"profile", "generic", "",
     "generic (the sensor runs the URI's schedule; no controls set) or mlx7502x (the proposed "
     "ToF controls, set and read back before every sequence, software trigger)"},
    {"subdev", "the video node", "", "the node with the sensor's controls, e.g. /dev/v4l-subdev0"},
    {"fmt", "Y12P (mlx7502x), Y12 (generic)", "", "pixel container: Y12, Y12P, Y16, BG12, pBCC"},
    {"width", "640", "px", "image width; the driver must grant it unchanged"},
    {"height", "480", "px", "image height (of one phase image); granted unchanged"},
    {"f", "20e6", "Hz", "base modulation frequency; harmonic j is modulated at j*f"},
    {"m", "3", "", "harmonics j = 1..m"},
    {"zeroth", "estimated", "",
     "zeroth moment: estimated, or proxy (four buckets at proxy_f); pair needs an emitter "
     "switch that no profile has"},
    {"proxy_f", "the sensor's lowest frequency (mlx7502x), 900e3 (generic)", "Hz",
     "frequency of the zeroth-moment proxy"},
    {"exposure", "500e-6", "s", "integration time of each phase (mlx7502x: whole microseconds)"},
    {"takes", "1", "", "repetitions of all sequences per transient frame"},
    {"phases", "0,90,180,270", "deg", "the order in which the sensor takes the four buckets"},
    {"scheme", "four-bucket", "",
     "four-bucket, or harmonic-cancellation (mlx7502x: each bucket from nphi frames at phase "
     "steps of 180/(nphi+1) deg with integration times in the scheme's shares, summed)"},
    {"nphi", "3", "", "harmonic-cancellation: sub-exposures per bucket (with 45 deg steps: 3)"},
    {"align", "trigger (mlx7502x), sequence (generic)", "",
     "buffers to sequences: trigger, sequence (driver sequence numbers) or gap (a pause)"},
    {"gap_ms", "5", "ms", "pause between sequences (align=gap; align=sequence checks with it)"},
    {"timeout_ms", "1000", "ms",
     "watchdog: no buffer for this long gives the sequence up (some of its frames came) or "
     "restarts the stream (none did)"},
    {"restart", "3", "", "stream restarts without a whole sequence before the source fails"},
    {"buffers", "8", "", "buffers to request (at least one sequence's)"},
    {"signed", "1 (mlx7502x), 0 (generic)", "", "samples are two's complement (A - B output)"},
    {"bits", "12", "", "significant bits of a sample"},
    {"shift", "0", "", "bits to drop on the right of each container word"},
    {"subframes", "1", "",
     "phase images per buffer, stacked vertically (a superframe sensor); 1 = one per buffer"},
    {"fx", "nominal 60 deg field of view", "px", "focal length x (fy, cx, cy likewise)"},
    {"ctrl.<name or 0xID>", "none", "",
     "a vendor control to set before streaming, e.g. ctrl.Output%20Mode=0 (comma-separated "
     "elements for an array)"},
};

absl::StatusOr<std::vector<int64_t>> ParseIntegers(absl::string_view text) {
  std::vector<int64_t> values;
  for (absl::string_view part : absl::StrSplit(text, ',')) {
    int64_t value;
    if (!absl::SimpleAtoi(part, &value)) {
      return absl::InvalidArgumentError(absl::StrCat("'", part, "' is not an integer"));
    }
    values.push_back(value);
  }
  return values;
}

}  // namespace

std::span<const SourceKey> V4l2Keys() { return kV4l2Keys; }

absl::StatusOr<V4l2Options> ParseV4l2Uri(absl::string_view uri) {
  absl::StatusOr<internal::SourceUri> parsed = internal::ParseSourceUri(uri);
  if (!parsed.ok()) return parsed.status();
  V4l2Options o;
  o.device = parsed->target;
  if (o.device.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(uri, ": no device; expected v4l2:/dev/videoN"));
  }
  // The profile first: it sets the defaults of other keys.
  for (const auto& [key, value] : parsed->keys) {
    if (key != "profile") continue;
    if (value == "generic") {
      o.profile = Profile::kGeneric;
    } else if (value == "mlx7502x") {
      o.profile = Profile::kMlx7502x;
    } else {
      return internal::BadKeyValue(uri, key, value, "generic or mlx7502x");
    }
  }
  const bool mlx = o.profile == Profile::kMlx7502x;
  o.sample = {.fourcc = mlx ? kFourccY12P : kFourccY12, .bits = 12, .shift = 0, .is_signed = mlx};
  o.assembly.alignment = mlx ? Alignment::kTrigger : Alignment::kSequence;
  o.schedule.base_frequency_hz = 20e6;
  o.schedule.order = 3;
  o.schedule.sampling = SamplingScheme::kFourBucket;
  o.schedule.phase_steps = 1;
  o.schedule.zeroth = ZerothScheme::kEstimated;
  o.schedule.exposure_s = 500e-6;
  double fx = 0, fy = 0, cx = NAN, cy = NAN;
  for (const auto& [key, value] : parsed->keys) {
    const auto number = [&, &key = key, &value = value](double* out,
                                                          absl::string_view expected) {
      if (!absl::SimpleAtod(value, out) || !std::isfinite(*out)) {
        return internal::BadKeyValue(uri, key, value, expected);
      }
      return absl::OkStatus();
    };
    const auto integer = [&, &key = key, &value = value](int* out, int low, int high) {
      if (!absl::SimpleAtoi(value, out) || *out < low || *out > high) {
        return internal::BadKeyValue(uri, key, value, absl::StrCat("an integer in ", low, "..", high));
      }
      return absl::OkStatus();
    };
    absl::Status status;
    if (key == "profile") {
      continue;
    } else if (key == "subdev") {
      o.subdev = value;
    } else if (key == "fmt") {
      bool found = false;
      for (uint32_t fourcc :
           {kFourccY12, kFourccY12P, kFourccY16, kFourccSBGGR12, kFourccSBGGR12P}) {
        if (value == FourccName(fourcc)) {
          o.sample.fourcc = fourcc;
          found = true;
        }
      }
      if (!found) return internal::BadKeyValue(uri, key, value, "Y12, Y12P, Y16, BG12 or pBCC");
      if (o.sample.fourcc == kFourccY16 && o.sample.bits == 12 && !o.sample.is_signed) {
        o.sample.bits = 16;
      }
    } else if (key == "width") {
      status = integer(&o.geometry.width, 2, 8192);
    } else if (key == "height") {
      status = integer(&o.geometry.height, 1, 8192);
    } else if (key == "f") {
      status = number(&o.schedule.base_frequency_hz, "a frequency in Hz");
    } else if (key == "m") {
      status = integer(&o.schedule.order, 1, kMaxOrder);
    } else if (key == "zeroth") {
      absl::StatusOr<ZerothScheme> zeroth = ParseZerothScheme(value);
      if (!zeroth.ok()) return internal::BadKeyValue(uri, key, value, "estimated or proxy");
      if (*zeroth == ZerothScheme::kUnmodulatedPair) {
        return absl::InvalidArgumentError(absl::StrCat(
            uri, ": zeroth = pair needs the emitter switched off for one exposure, and no "
                 "profile has a way to (the mlx7502x driver dropped its LED GPIO); use "
                 "estimated or proxy"));
      }
      o.schedule.zeroth = *zeroth;
    } else if (key == "proxy_f") {
      status = number(&o.schedule.proxy_frequency_hz, "a frequency in Hz");
      o.proxy_given = true;
    } else if (key == "exposure") {
      status = number(&o.schedule.exposure_s, "an integration time in s");
    } else if (key == "takes") {
      status = integer(&o.schedule.takes, 1, 1024);
    } else if (key == "phases") {
      absl::StatusOr<std::vector<int64_t>> phases = ParseIntegers(value);
      std::vector<int64_t> sorted = phases.ok() ? *phases : std::vector<int64_t>{};
      std::sort(sorted.begin(), sorted.end());
      if (sorted != std::vector<int64_t>{0, 90, 180, 270}) {
        return internal::BadKeyValue(uri, key, value,
                        "the four buckets 0,90,180,270 in the order the sensor takes them "
                        "(four-bucket sampling; other steps are not supported yet)");
      }
      o.phases_deg = *phases;
    } else if (key == "scheme") {
      absl::StatusOr<SamplingScheme> scheme = ParseSamplingScheme(value);
      if (!scheme.ok() || *scheme == SamplingScheme::kArccos) {
        return internal::BadKeyValue(uri, key, value,
                        "four-bucket or harmonic-cancellation (arccos sampling shifts the phase "
                        "within one exposure, which these sensors cannot)");
      }
      o.schedule.sampling = *scheme;
    } else if (key == "nphi") {
      status = integer(&o.schedule.phase_steps, 1, 64);
    } else if (key == "align") {
      if (absl::Status s = ParseAlignment(value, &o.assembly.alignment); !s.ok()) {
        return internal::BadKeyValue(uri, key, value, "trigger, sequence or gap");
      }
    } else if (key == "gap_ms") {
      double ms = 0;
      status = number(&ms, "a pause in ms");
      if (status.ok() && ms < 0) status = internal::BadKeyValue(uri, key, value, "a pause >= 0 ms");
      o.assembly.gap_ns = static_cast<int64_t>(std::llround(ms * 1e6));
    } else if (key == "timeout_ms") {
      int ms = 0;
      status = integer(&ms, 1, 3'600'000);
      o.watchdog = absl::Milliseconds(ms);
    } else if (key == "restart") {
      status = integer(&o.restarts, 0, 1000);
    } else if (key == "buffers") {
      status = integer(&o.buffers, 1, 64);
    } else if (key == "signed") {
      if (value != "0" && value != "1") return internal::BadKeyValue(uri, key, value, "0 or 1");
      o.sample.is_signed = value == "1";
    } else if (key == "bits") {
      status = integer(&o.sample.bits, 1, 16);
    } else if (key == "shift") {
      status = integer(&o.sample.shift, 0, 15);
    } else if (key == "subframes") {
      status = integer(&o.subframes, 1, 64);
    } else if (key == "fx") {
      status = number(&fx, "a focal length in px");
    } else if (key == "fy") {
      status = number(&fy, "a focal length in px");
    } else if (key == "cx") {
      status = number(&cx, "a principal point in px");
    } else if (key == "cy") {
      status = number(&cy, "a principal point in px");
    } else if (absl::StartsWith(key, "ctrl.")) {
      absl::StatusOr<std::vector<int64_t>> values = ParseIntegers(value);
      if (!values.ok()) return internal::BadKeyValue(uri, key, value, "integers separated by commas");
      o.passthrough.emplace_back(key.substr(5), *values);
    } else {
      return absl::InvalidArgumentError(absl::StrCat(
          uri, ": unknown key '", key, "' (transient sources lists the keys of v4l2:)"));
    }
    if (!status.ok()) return status;
  }
  if (o.schedule.zeroth == ZerothScheme::kLowFrequencyProxy && !o.proxy_given && !mlx) {
    o.schedule.proxy_frequency_hz = 900e3;
  }
  if (absl::Status s = o.sample.Validate(); !s.ok()) return WithContext(uri, s);
  if (o.schedule.sampling == SamplingScheme::kFourBucket) {
    o.schedule.phase_steps = 1;
  } else if (!mlx) {
    return absl::InvalidArgumentError(absl::StrCat(
        uri, ": scheme = harmonic-cancellation needs profile mlx7502x: the source builds it by "
             "setting the phases and integration times of each sub-exposure"));
  }
  if (mlx && o.assembly.alignment != Alignment::kTrigger) {
    return absl::InvalidArgumentError(absl::StrCat(
        uri, ": profile mlx7502x needs align=trigger: it sets a new frequency before every "
             "sequence, which the sensor's continuous mode cannot follow"));
  }
  const double fov = 60.0 * std::numbers::pi / 180.0;
  o.intrinsics.fx = fx > 0 ? fx : o.geometry.width / (2.0 * std::tan(fov / 2));
  o.intrinsics.fy = fy > 0 ? fy : o.intrinsics.fx;
  o.intrinsics.cx = std::isfinite(cx) ? cx : (o.geometry.width - 1) / 2.0;
  o.intrinsics.cy = std::isfinite(cy) ? cy : (o.geometry.height - 1) / 2.0;
  return o;
}


}  // namespace transient::v4l2
