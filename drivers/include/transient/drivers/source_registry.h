// The capture sources by URI scheme (DESIGN.md, "The data path"): every source family
// registers its scheme, the syntax of its URIs, its keys with defaults and units, what it can
// do, and how to open it. Nothing outside drivers/ takes a source URI apart: the daemon and the
// tool ask here. A new source is a folder under drivers/src/ and one line in
// drivers/src/registered_sources.cc (drivers/README.md says how).
#pragma once

#include <memory>
#include <span>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "transient/drivers/capture_source.h"

namespace transient {

// A key of a source URI ("?key=value"), for help texts and the docs.
struct SourceKey {
  absl::string_view name;
  absl::string_view default_value;
  absl::string_view unit;  // "" when dimensionless
  absl::string_view description;
};

// What the sources of a scheme can do, known without opening one.
struct SchemeCapabilities {
  bool ground_truth = false;          // GroundTruthAt answers (a simulated scene)
  bool seek = false;                  // can start at a chosen capture cycle
  bool pace = false;                  // realtime or as fast as the consumer takes frames
  bool embedded_calibration = false;  // an opened source may carry its own calibration
  bool calibration_scene = false;     // CalibrationSourceFor names the same camera on a Dirac
  bool adjustable_takes = false;      // SourceUriWithTakes can change the schedule's takes
  bool delivers_depth = false;        // a depth camera (SamplingScheme::kDepth): no calibration
};

struct SourceScheme {
  absl::string_view name;         // the URI scheme, e.g. "sim"
  absl::string_view syntax;       // e.g. "sim:<scene>?key=value&..."
  absl::string_view description;  // one line
  std::span<const SourceKey> keys;
  SchemeCapabilities capabilities;
  // Opens a URI of this scheme; InvalidArgument naming the key or value that is wrong.
  absl::StatusOr<std::unique_ptr<CaptureSource>> (*open)(absl::string_view uri) = nullptr;
  // The URI of the same camera looking at a Dirac at zero (thesis §8.3.2, fig. 8.3), paced as
  // fast as possible; set when capabilities.calibration_scene.
  absl::StatusOr<std::string> (*calibration_source)(absl::string_view uri) = nullptr;
  // The URI with the schedule's takes per frame changed; set when capabilities.adjustable_takes.
  absl::StatusOr<std::string> (*with_takes)(absl::string_view uri, int takes) = nullptr;
};

// Every registered scheme, in the order of registered_sources.cc.
std::span<const SourceScheme* const> SourceSchemes();

// The scheme of `uri` ("sim" for "sim:mirrors?m=3"). InvalidArgument naming the URI and the
// schemes there are when it has none of them.
[[nodiscard]] absl::StatusOr<const SourceScheme*> FindSourceScheme(absl::string_view uri);

// The URI of the same camera looking at a Dirac at zero, to calibrate `uri` against.
// InvalidArgument when the scheme has no calibration scene (a real camera must be pointed into
// its light source, and that source named), or the URI's own errors.
[[nodiscard]] absl::StatusOr<std::string> CalibrationSourceFor(absl::string_view uri);

// `uri` with `takes` takes per frame. FailedPrecondition when the scheme fixes its schedule;
// InvalidArgument when the schedule would be impossible.
[[nodiscard]] absl::StatusOr<std::string> SourceUriWithTakes(absl::string_view uri, int takes);

// The schemes with their syntax, capabilities and keys, as text for --help and
// `transient sources`.
std::string DescribeSourceSchemes();

}  // namespace transient
