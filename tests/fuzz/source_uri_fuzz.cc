// Source URIs (--source, Calibrate's source_uri): any string through every parser that takes
// one without opening anything (the registry's split, the simulator's, replay's and V4L2's
// keys). Property: a simulator URI that parses formats to one that parses to the same URI.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "source_uri.h"
#include "transient/drivers/replay_source.h"
#include "transient/drivers/simulator.h"
#include "transient/drivers/source_registry.h"
#include "v4l2/v4l2_options.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const absl::string_view uri(reinterpret_cast<const char*>(data), size);
  (void)transient::internal::ParseSourceUri(uri);
  (void)transient::FindSourceScheme(uri);
  std::string path;
  (void)transient::ParseReplayUri(uri, &path);
  (void)transient::v4l2::ParseV4l2Uri(uri);
  absl::StatusOr<transient::SimulatorOptions> simulator = transient::ParseSimulatorUri(uri);
  if (simulator.ok()) {
    const std::string formatted = transient::FormatSimulatorUri(*simulator);
    absl::StatusOr<transient::SimulatorOptions> again = transient::ParseSimulatorUri(formatted);
    if (!again.ok() || transient::FormatSimulatorUri(*again) != formatted) std::abort();
  }
  return 0;
}
