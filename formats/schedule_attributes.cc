// Writing and reading the schedule attributes of captures and calibrations.
#include "schedule_attributes.h"

#include <cstdint>
#include <string>

#include "absl/strings/str_cat.h"
#include "transient/formats/h5.h"
#include "transient/reconstruct/moments.h"

namespace transient {
namespace {

// Generous bounds for the counts, far beyond any schedule that validates, so that a corrupt
// value is named here rather than overflowing an int.
constexpr int64_t kMaxCount = int64_t{1} << 20;

}  // namespace

absl::Status WriteScheduleAttributes(hid_t object, const ScheduleOptions& schedule) {
  if (schedule.DeliversDepth()) {
    return absl::FailedPreconditionError(schedule.MissingHarmonicsText("a schedule attribute set"));
  }
  absl::Status status =
      h5::WriteDoubleAttribute(object, "base_frequency_hz", schedule.base_frequency_hz);
  status.Update(h5::WriteInt64Attribute(object, "order", schedule.order));
  status.Update(
      h5::WriteStringAttribute(object, "sampling", SamplingSchemeName(schedule.sampling)));
  status.Update(h5::WriteInt64Attribute(object, "phase_steps", schedule.phase_steps));
  status.Update(h5::WriteStringAttribute(object, "zeroth", ZerothSchemeName(schedule.zeroth)));
  status.Update(
      h5::WriteDoubleAttribute(object, "proxy_frequency_hz", schedule.proxy_frequency_hz));
  status.Update(h5::WriteDoubleAttribute(object, "exposure_s", schedule.exposure_s));
  status.Update(h5::WriteInt64Attribute(object, "takes", schedule.takes));
  status.Update(h5::WriteInt64Attribute(object, "buckets", schedule.buckets));
  if (!schedule.harmonics.empty()) {
    status.Update(
        h5::WriteStringAttribute(object, "harmonics", FormatHarmonicList(schedule.harmonics)));
  } else if (H5Aexists(object, "harmonics") > 0 && H5Adelete(object, "harmonics") < 0) {
    status.Update(absl::InternalError("cannot delete attribute harmonics"));
  }
  return status;
}

absl::StatusOr<ScheduleOptions> ReadScheduleAttributes(hid_t object, absl::string_view where,
                                                       TakesAttribute takes) {
  absl::StatusOr<double> frequency =
      h5::ReadFiniteAttribute(object, "base_frequency_hz", where, h5::Sign::kPositive);
  if (!frequency.ok()) return frequency.status();
  absl::StatusOr<int64_t> order = h5::ReadIntegerAttribute(object, "order", where, 1, kMaxOrder);
  if (!order.ok()) return order.status();
  absl::StatusOr<std::string> sampling = h5::ReadStringAttribute(object, "sampling", where);
  if (!sampling.ok()) return sampling.status();
  absl::StatusOr<SamplingScheme> sampling_scheme = ParseSamplingScheme(*sampling);
  if (!sampling_scheme.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": attribute sampling: ", sampling_scheme.status().message()));
  }
  absl::StatusOr<int64_t> phase_steps =
      h5::ReadIntegerAttribute(object, "phase_steps", where, 1, kMaxCount);
  if (!phase_steps.ok()) return phase_steps.status();
  absl::StatusOr<std::string> zeroth = h5::ReadStringAttribute(object, "zeroth", where);
  if (!zeroth.ok()) return zeroth.status();
  absl::StatusOr<ZerothScheme> zeroth_scheme = ParseZerothScheme(*zeroth);
  if (!zeroth_scheme.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": attribute zeroth: ", zeroth_scheme.status().message()));
  }
  absl::StatusOr<double> proxy =
      h5::ReadFiniteAttribute(object, "proxy_frequency_hz", where, h5::Sign::kNonNegative);
  if (!proxy.ok()) return proxy.status();
  absl::StatusOr<double> exposure =
      h5::ReadFiniteAttribute(object, "exposure_s", where, h5::Sign::kPositive);
  if (!exposure.ok()) return exposure.status();
  int64_t take_count = 1;
  if (takes == TakesAttribute::kRequired || H5Aexists(object, "takes") > 0) {
    absl::StatusOr<int64_t> value = h5::ReadIntegerAttribute(object, "takes", where, 1, kMaxCount);
    if (!value.ok()) return value.status();
    take_count = *value;
  }
  // Files written before N-step sampling and harmonic sets have neither: four buckets, 1..m.
  int64_t buckets = 4;
  if (H5Aexists(object, "buckets") > 0) {
    absl::StatusOr<int64_t> value = h5::ReadIntegerAttribute(object, "buckets", where,
                                                             kMinPhaseBuckets, kMaxPhaseBuckets);
    if (!value.ok()) return value.status();
    buckets = *value;
  }
  std::vector<int> harmonics;
  if (H5Aexists(object, "harmonics") > 0) {
    absl::StatusOr<std::string> text = h5::ReadStringAttribute(object, "harmonics", where);
    if (!text.ok()) return text.status();
    absl::StatusOr<std::vector<int>> parsed = ParseHarmonicList(*text);
    if (!parsed.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ": attribute harmonics: ", parsed.status().message()));
    }
    harmonics = *std::move(parsed);
  }
  return ScheduleOptions{.base_frequency_hz = *frequency,
                         .order = static_cast<int>(*order),
                         .harmonics = std::move(harmonics),
                         .buckets = static_cast<int>(buckets),
                         .sampling = *sampling_scheme,
                         .phase_steps = static_cast<int>(*phase_steps),
                         .zeroth = *zeroth_scheme,
                         .proxy_frequency_hz = *proxy,
                         .exposure_s = *exposure,
                         .takes = static_cast<int>(take_count)};
}

}  // namespace transient
