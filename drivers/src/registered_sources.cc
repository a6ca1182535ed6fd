// The registry: one line per source family, its scheme object defined in its folder.
#include <algorithm>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "source_uri.h"
#include "transient/drivers/source_registry.h"

namespace transient {
namespace internal {
extern const SourceScheme kSimulatorScheme;  // src/sim/simulator_scheme.cc
extern const SourceScheme kReplayScheme;     // src/replay/replay_scheme.cc
extern const SourceScheme kV4l2Scheme;       // src/v4l2/v4l2_source.cc
extern const SourceScheme kUsbScheme;        // src/kinect2/kinect2_source.cc
extern const SourceScheme kOpenNi2Scheme;    // src/openni2/openni2_source.cc
}  // namespace internal

namespace {

const SourceScheme* const kSchemes[] = {
    &internal::kSimulatorScheme,
    &internal::kReplayScheme,
    &internal::kV4l2Scheme,
    &internal::kUsbScheme,
    &internal::kOpenNi2Scheme,
};

std::string SchemeNames() {
  std::vector<std::string> names;
  for (const SourceScheme* scheme : kSchemes) names.push_back(std::string(scheme->syntax));
  return absl::StrJoin(names, " or ");
}

}  // namespace

std::span<const SourceScheme* const> SourceSchemes() { return kSchemes; }

absl::StatusOr<const SourceScheme*> FindSourceScheme(absl::string_view uri) {
  const size_t colon = uri.find(':');
  const absl::string_view scheme = uri.substr(0, colon);
  if (colon != absl::string_view::npos) {
    for (const SourceScheme* candidate : kSchemes) {
      if (candidate->name == scheme) return candidate;
    }
  }
  return absl::InvalidArgumentError(
      absl::StrCat("unknown source '", uri, "'; expected ", SchemeNames(),
                   " (transient sources lists them)"));
}

absl::StatusOr<std::unique_ptr<CaptureSource>> OpenSource(absl::string_view uri) {
  absl::StatusOr<const SourceScheme*> scheme = FindSourceScheme(uri);
  if (!scheme.ok()) return scheme.status();
  return (*scheme)->open(uri);
}

absl::StatusOr<std::string> CalibrationSourceFor(absl::string_view uri) {
  absl::StatusOr<const SourceScheme*> scheme = FindSourceScheme(uri);
  if (!scheme.ok()) return scheme.status();
  if ((*scheme)->calibration_source == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat(
        uri, ": a ", (*scheme)->name,
        " source has no calibration scene (only a simulator has one; point a camera into its "
        "light source, thesis fig. 8.3, and name that source)"));
  }
  return (*scheme)->calibration_source(uri);
}

absl::StatusOr<std::string> SourceUriWithTakes(absl::string_view uri, int takes) {
  absl::StatusOr<const SourceScheme*> scheme = FindSourceScheme(uri);
  if (!scheme.ok()) return scheme.status();
  if ((*scheme)->with_takes == nullptr) {
    return absl::FailedPreconditionError(
        absl::StrCat("the source ", uri, " fixes its schedule; only a source whose URI sets "
                     "the takes (sim:) can change them"));
  }
  return (*scheme)->with_takes(uri, takes);
}

std::string DescribeSourceSchemes() {
  std::string text;
  for (const SourceScheme* scheme : kSchemes) {
    const SchemeCapabilities& c = scheme->capabilities;
    std::vector<std::string> can;
    if (c.ground_truth) can.push_back("ground truth");
    if (c.seek) can.push_back("seek");
    if (c.pace) can.push_back("pace");
    if (c.embedded_calibration) can.push_back("embedded calibration");
    if (c.calibration_scene) can.push_back("calibration scene");
    if (c.adjustable_takes) can.push_back("takes");
    if (c.delivers_depth) can.push_back("depth only");
    absl::StrAppend(&text, scheme->syntax, "\n  ", scheme->description, "\n  capabilities: ",
                    can.empty() ? "none" : absl::StrJoin(can, ", "), "\n");
    for (const SourceKey& key : scheme->keys) {
      absl::StrAppend(&text, "  ", key.name, " (default ", key.default_value,
                      key.unit.empty() ? "" : absl::StrCat(" ", key.unit), "): ",
                      key.description, "\n");
    }
  }
  return text;
}

}  // namespace transient
