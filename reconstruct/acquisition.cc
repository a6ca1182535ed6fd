// Acquisition schedules: the exposure list of one capture cycle and the sub-exposure split of
// thesis §8.3.1.
#include "transient/reconstruct/acquisition.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "transient/reconstruct/physical_constants.h"

namespace transient {
namespace {

constexpr double kPi = std::numbers::pi;
// Matching of recorded floating-point metadata: values written by a source and read back from a
// file are equal to far better than this; a different configuration differs by far more.
constexpr double kRelativeMatch = 1e-6;

bool Near(double a, double b) { return std::abs(a - b) <= kRelativeMatch * std::max(1.0, std::abs(b)); }

std::vector<SubExposure> MakeSubExposures(const ScheduleOptions& options) {
  const int n = options.phase_steps;
  std::vector<SubExposure> split;
  switch (options.sampling) {
    case SamplingScheme::kFourBucket:
    case SamplingScheme::kDepth:  // no modulation; the split is unused
      split.push_back({0.0, 1.0});
      break;
    case SamplingScheme::kArccos:  // thesis eq. 8.7: equal shares
      for (int k = 0; k < n; ++k) {
        split.push_back({std::acos(1.0 - (2.0 * k + 1.0) / n), 1.0 / n});
      }
      break;
    case SamplingScheme::kHarmonicCancellation: {  // Payne et al. 2010, thesis §8.3.1
      double total = 0.0;
      for (int k = 0; k < n; ++k) total += std::sin((k + 1) * kPi / (n + 1));
      for (int k = 0; k < n; ++k) {
        split.push_back({k * kPi / (n + 1), std::sin((k + 1) * kPi / (n + 1)) / total});
      }
      break;
    }
  }
  return split;
}

std::string FrequencyText(double hz) {
  if (hz >= 1e6) return absl::StrFormat("%g MHz", hz / 1e6);
  if (hz >= 1e3) return absl::StrFormat("%g kHz", hz / 1e3);
  return absl::StrFormat("%g Hz", hz);
}

}  // namespace

absl::string_view SamplingSchemeName(SamplingScheme scheme) {
  switch (scheme) {
    case SamplingScheme::kFourBucket: return "four-bucket";
    case SamplingScheme::kArccos: return "arccos";
    case SamplingScheme::kHarmonicCancellation: return "harmonic-cancellation";
    case SamplingScheme::kDepth: return "depth";
  }
  return "unknown";
}

absl::string_view FrameContentName(FrameContent content) {
  switch (content) {
    case FrameContent::kModulated: return "modulated";
    case FrameContent::kDepth: return "depth";
    case FrameContent::kAmplitude: return "amplitude";
  }
  return "unknown";
}

absl::string_view ZerothSchemeName(ZerothScheme scheme) {
  switch (scheme) {
    case ZerothScheme::kUnmodulatedPair: return "pair";
    case ZerothScheme::kLowFrequencyProxy: return "proxy";
    case ZerothScheme::kEstimated: return "estimated";
  }
  return "unknown";
}

absl::StatusOr<SamplingScheme> ParseSamplingScheme(absl::string_view name) {
  for (SamplingScheme s : {SamplingScheme::kFourBucket, SamplingScheme::kArccos,
                           SamplingScheme::kHarmonicCancellation}) {
    if (name == SamplingSchemeName(s)) return s;
  }
  if (name == SamplingSchemeName(SamplingScheme::kDepth)) {
    return absl::InvalidArgumentError(
        "sampling scheme 'depth' is a depth camera's, which only its source declares: it holds "
        "no modulated captures; expected four-bucket, arccos or harmonic-cancellation");
  }
  return absl::InvalidArgumentError(absl::StrCat(
      "unknown sampling scheme '", name, "'; expected four-bucket, arccos or harmonic-cancellation"));
}

absl::StatusOr<ZerothScheme> ParseZerothScheme(absl::string_view name) {
  for (ZerothScheme s : {ZerothScheme::kUnmodulatedPair, ZerothScheme::kLowFrequencyProxy,
                         ZerothScheme::kEstimated}) {
    if (name == ZerothSchemeName(s)) return s;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("unknown zeroth-moment scheme '", name, "'; expected pair, proxy or estimated"));
}

absl::Status ScheduleOptions::Validate() const {
  auto violated = [](absl::string_view field, auto value, absl::string_view rule) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, " = ", value, ". Violated constraint: ", rule));
  };
  if (!std::isfinite(base_frequency_hz) || base_frequency_hz <= 0.0) {
    return violated("base_frequency_hz", base_frequency_hz, "finite and > 0");
  }
  if (order < 1 || order > kMaxOrder) {
    return violated("order", order, absl::StrCat("1 <= order <= ", kMaxOrder));
  }
  if (!harmonics.empty()) {
    std::vector<bool> seen(kMaxOrder + 1, false);
    int highest = 0;
    for (int j : harmonics) {
      if (j < 1 || j > kMaxOrder) {
        return violated("harmonics", FormatHarmonicList(harmonics),
                        absl::StrCat("every harmonic in 1..", kMaxOrder, " (found ", j, ")"));
      }
      if (seen[static_cast<size_t>(j)]) {
        return violated("harmonics", FormatHarmonicList(harmonics),
                        absl::StrCat("distinct harmonics (", j, " twice)"));
      }
      seen[static_cast<size_t>(j)] = true;
      highest = std::max(highest, j);
    }
    int common = 0;
    for (int j : harmonics) common = std::gcd(common, j);
    if (common > 1) {
      return violated("harmonics", FormatHarmonicList(harmonics),
                      absl::StrCat("no common factor (", common, "): describe them as harmonics of ",
                                   common, " * base_frequency_hz"));
    }
    if (order != highest) {
      return violated("order", order,
                      absl::StrCat("order = max(harmonics) = ", highest, " (harmonics ",
                                   FormatHarmonicList(harmonics), ")"));
    }
  }
  if (buckets < kMinPhaseBuckets || buckets > kMaxPhaseBuckets) {
    return violated("buckets", buckets,
                    absl::StrCat(kMinPhaseBuckets, " <= buckets <= ", kMaxPhaseBuckets));
  }
  if (phase_steps < 1 || phase_steps > 64) {
    return violated("phase_steps", phase_steps, "1 <= phase_steps <= 64");
  }
  if (zeroth == ZerothScheme::kLowFrequencyProxy &&
      (!std::isfinite(proxy_frequency_hz) || proxy_frequency_hz <= 0.0 ||
       proxy_frequency_hz >= base_frequency_hz)) {
    return violated("proxy_frequency_hz", proxy_frequency_hz,
                    absl::StrCat("0 < proxy_frequency_hz < base_frequency_hz = ", base_frequency_hz));
  }
  if (!std::isfinite(exposure_s) || exposure_s <= 0.0 || exposure_s > 10.0) {
    return violated("exposure_s", exposure_s, "0 < exposure_s <= 10");
  }
  if (takes < 1 || takes > 1024) return violated("takes", takes, "1 <= takes <= 1024");
  if (DeliversDepth()) {
    if (!std::isfinite(max_depth_m) || max_depth_m <= 0.0) {
      return violated("max_depth_m", max_depth_m, "finite and > 0 with sampling = depth");
    }
    if (takes != 1) {
      return violated("takes", takes, "takes = 1 with sampling = depth (depth is not averaged)");
    }
    if (!harmonics.empty()) {
      return violated("harmonics", FormatHarmonicList(harmonics),
                      "empty with sampling = depth (a depth camera measures no harmonic)");
    }
  } else {
    if (max_depth_m != 0.0) {
      return violated("max_depth_m", max_depth_m,
                      "0 unless sampling = depth (a modulated schedule's range limit is c/(2f))");
    }
    if (depth_amplitude) {
      return violated("depth_amplitude", "true", "false unless sampling = depth");
    }
  }
  return absl::OkStatus();
}

std::vector<int> ScheduleOptions::MeasuredHarmonics() const {
  if (DeliversDepth()) return {};
  if (!harmonics.empty()) return harmonics;
  std::vector<int> all(static_cast<size_t>(std::max(order, 0)));
  for (int j = 1; j <= order; ++j) all[static_cast<size_t>(j - 1)] = j;
  return all;
}

bool ScheduleOptions::HasAllHarmonics() const {
  if (DeliversDepth()) return false;
  if (harmonics.empty()) return true;
  std::vector<bool> seen(static_cast<size_t>(order) + 1, false);
  for (int j : harmonics) {
    if (j >= 1 && j <= order) seen[static_cast<size_t>(j)] = true;
  }
  for (int j = 1; j <= order; ++j) {
    if (!seen[static_cast<size_t>(j)]) return false;
  }
  return true;
}

std::string ScheduleOptions::MissingHarmonicsText(absl::string_view what) const {
  if (HasAllHarmonics()) return "";
  if (DeliversDepth()) {
    return absl::StrCat("the source delivers depth, not modulated captures: ", what,
                        " needs modulated captures");
  }
  std::vector<bool> seen(static_cast<size_t>(order) + 1, false);
  for (int j : harmonics) {
    if (j >= 1 && j <= order) seen[static_cast<size_t>(j)] = true;
  }
  // Runs of missing harmonics: "1, 3-9, 11-14".
  std::vector<std::string> runs;
  for (int j = 1; j <= order; ++j) {
    if (seen[static_cast<size_t>(j)]) continue;
    int last = j;
    while (last + 1 <= order && !seen[static_cast<size_t>(last + 1)]) ++last;
    runs.push_back(last == j ? absl::StrCat(j) : absl::StrCat(j, "-", last));
    j = last;
  }
  std::vector<int> sorted = harmonics;
  std::sort(sorted.begin(), sorted.end());
  return absl::StrCat("the schedule measures harmonics ", absl::StrJoin(sorted, ", "), " of ",
                      FrequencyText(base_frequency_hz), "; ", what,
                      " needs every harmonic 1..", order, " (missing ", absl::StrJoin(runs, ", "),
                      ")");
}

double ScheduleOptions::UnambiguousRangeM() const {
  return DeliversDepth() ? max_depth_m : UnambiguousRange(base_frequency_hz);
}

double BucketPhaseShift(int k, int buckets) { return 2.0 * kPi * k / buckets; }

int BucketIndex(double phase_shift_rad, int buckets) {
  const long k = std::lround(phase_shift_rad * buckets / (2.0 * kPi));
  return static_cast<int>(((k % buckets) + buckets) % buckets);
}

std::string FormatHarmonicList(std::span<const int> harmonics) {
  return absl::StrJoin(harmonics, ",");
}

absl::StatusOr<std::vector<int>> ParseHarmonicList(absl::string_view text) {
  std::vector<int> harmonics;
  for (absl::string_view entry : absl::StrSplit(text, ',')) {
    int j = 0;
    if (!absl::SimpleAtoi(entry, &j)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "harmonic list '", text, "': '", entry, "' is not an integer; expected e.g. 10,2,15"));
    }
    harmonics.push_back(j);
  }
  return harmonics;
}

absl::StatusOr<AcquisitionSchedule> AcquisitionSchedule::Create(const ScheduleOptions& options) {
  if (absl::Status status = options.Validate(); !status.ok()) return status;
  AcquisitionSchedule schedule;
  schedule.options_ = options;
  if (options.sampling == SamplingScheme::kFourBucket) schedule.options_.phase_steps = 1;
  schedule.sub_exposures_ = MakeSubExposures(schedule.options_);
  Complex gain{0.0, 0.0};
  for (const SubExposure& s : schedule.sub_exposures_) {
    gain += s.weight * std::polar(1.0, -s.phase_shift_rad);
  }
  schedule.nominal_gain_ = gain;
  std::vector<double> buckets(static_cast<size_t>(options.buckets));
  for (int k = 0; k < options.buckets; ++k) {
    buckets[static_cast<size_t>(k)] = BucketPhaseShift(k, options.buckets);
  }

  if (options.DeliversDepth()) {
    for (FrameContent content : {FrameContent::kDepth, FrameContent::kAmplitude}) {
      if (content == FrameContent::kAmplitude && !options.depth_amplitude) break;
      ExposureConfig e;
      e.exposure_s = options.exposure_s;
      e.content = content;
      schedule.exposures_.push_back(e);
    }
    return schedule;
  }
  for (int take = 0; take < options.takes; ++take) {
    auto add = [&](int harmonic, double frequency_hz, double shift, bool illumination) {
      ExposureConfig e;
      e.harmonic = harmonic;
      e.frequency_hz = frequency_hz;
      e.phase_shift_rad = shift;
      e.exposure_s = options.exposure_s;
      e.illumination = illumination;
      e.take = take;
      schedule.exposures_.push_back(e);
    };
    switch (options.zeroth) {
      case ZerothScheme::kUnmodulatedPair:
        add(0, 0.0, 0.0, true);
        add(0, 0.0, 0.0, false);
        break;
      case ZerothScheme::kLowFrequencyProxy:
        for (double b : buckets) add(0, options.proxy_frequency_hz, b, true);
        break;
      case ZerothScheme::kEstimated:
        break;
    }
    for (int j : options.MeasuredHarmonics()) {
      for (double b : buckets) add(j, j * options.base_frequency_hz, b, true);
    }
  }
  return schedule;
}

absl::StatusOr<int> AcquisitionSchedule::IndexOf(const ExposureConfig& config) const {
  for (size_t i = 0; i < exposures_.size(); ++i) {
    const ExposureConfig& e = exposures_[i];
    if (e.content == config.content && e.harmonic == config.harmonic && e.take == config.take &&
        e.illumination == config.illumination && Near(config.frequency_hz, e.frequency_hz) &&
        std::abs(config.phase_shift_rad - e.phase_shift_rad) <= kRelativeMatch &&
        Near(config.exposure_s, e.exposure_s)) {
      return static_cast<int>(i);
    }
  }
  return absl::InvalidArgumentError(absl::StrCat(
      DescribeFrame(config), " is not an exposure of the schedule ", Describe()));
}

std::string AcquisitionSchedule::Describe() const {
  if (options_.DeliversDepth()) {
    return absl::StrCat("depth camera (Z up to ", options_.max_depth_m, " m)",
                        options_.depth_amplitude ? ", with amplitude" : "", ": ",
                        raw_frames_per_frame(), raw_frames_per_frame() == 1 ? " raw frame" : " raw frames");
  }
  std::string sampling(SamplingSchemeName(options_.sampling));
  if (options_.sampling != SamplingScheme::kFourBucket) {
    absl::StrAppend(&sampling, " (n_phi = ", options_.phase_steps, ")");
  }
  if (options_.buckets != 4) {
    // kFourBucket is one phase per exposure; with N steps it is N-step sampling.
    sampling = options_.sampling == SamplingScheme::kFourBucket
                   ? absl::StrCat(options_.buckets, "-step")
                   : absl::StrCat(sampling, ", ", options_.buckets, "-step");
  }
  std::string zeroth(ZerothSchemeName(options_.zeroth));
  if (options_.zeroth == ZerothScheme::kLowFrequencyProxy) {
    absl::StrAppend(&zeroth, " at ", FrequencyText(options_.proxy_frequency_hz));
  }
  const std::string harmonics =
      options_.harmonics.empty()
          ? absl::StrCat("m = ", options_.order)
          : absl::StrCat("harmonics ", absl::StrJoin(options_.harmonics, ", "));
  return absl::StrCat("f = ", FrequencyText(options_.base_frequency_hz), ", ", harmonics,
                      ", ", sampling, ", zeroth: ", zeroth, ", ", options_.takes,
                      options_.takes == 1 ? " take: " : " takes: ", raw_frames_per_frame(),
                      " raw frames");
}

std::string DescribeExposure(const ExposureConfig& config) {
  if (config.content != FrameContent::kModulated) {
    return absl::StrCat(config.content == FrameContent::kDepth ? "depth (Z, m)" : "amplitude",
                        ", take ", config.take);
  }
  return absl::StrFormat(
      "harmonic %d (%s), phase shift %.4f rad, exposure %g ms, illumination %s, take %d",
      config.harmonic, FrequencyText(config.frequency_hz), config.phase_shift_rad,
      config.exposure_s * 1e3, config.illumination ? "on" : "off", config.take);
}

std::string DescribeFrame(const ExposureConfig& config) {
  return absl::StrCat("frame ", config.sequence, " (cycle ", config.cycle, ", ",
                      DescribeExposure(config), ")");
}

}  // namespace transient
