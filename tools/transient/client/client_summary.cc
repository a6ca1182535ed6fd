#include "tools/transient/client/client_summary.h"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "tools/transient/client/product_images.h"
#include "tools/transient/common/json_text.h"
#include "tools/transient/common/image_writers.h"

namespace transient::tools {

std::string ClientSummaryJson(const ClientSummary& summary) {
  std::string json = "{\n";
  absl::StrAppend(&json, "  \"address\": ", JsonString(summary.address), ",\n");
  absl::StrAppend(&json, "  \"source_uri\": ", JsonString(summary.source_uri), ",\n");
  absl::StrAppend(&json, "  \"daemon_version\": ", JsonString(summary.version), ",\n");
  absl::StrAppend(&json, "  \"camera\": {\"width\": ", summary.camera_width,
                  ", \"height\": ", summary.camera_height, "},\n");
  absl::StrAppend(&json, "  \"frames\": ", summary.frames, ",\n");
  absl::StrAppend(&json, "  \"corrupt_frames\": ", summary.corrupt_frames, ",\n");
  absl::StrAppend(&json, "  \"state_announcements\": ", summary.state_announcements, ",\n");
  absl::StrAppend(&json, "  \"seconds\": ", JsonNumber(summary.seconds), ",\n");
  absl::StrAppend(&json, "  \"rate_hz\": ", JsonNumber(summary.rate_hz), ",\n");
  absl::StrAppend(&json, "  \"latency_ms\": {\"p50\": ", JsonNumber(summary.latency.p50_ms),
                  ", \"p90\": ", JsonNumber(summary.latency.p90_ms),
                  ", \"p99\": ", JsonNumber(summary.latency.p99_ms),
                  ", \"max\": ", JsonNumber(summary.latency.max_ms), "},\n");
  absl::StrAppend(&json, "  \"frames_missed\": ", summary.frames_missed, ",\n");
  if (summary.source_counters) {
    std::vector<std::string> counters;
    for (const auto& [name, value] : *summary.source_counters) {
      counters.push_back(absl::StrCat(JsonString(name), ": ", value));
    }
    absl::StrAppend(&json, "  \"source_counters\": {", absl::StrJoin(counters, ", "), "},\n");
  } else {
    absl::StrAppend(&json, "  \"source_counters\": null,\n");
  }
  std::vector<std::string> changes;
  for (const ClientStateChange& change : summary.state_changes) {
    changes.push_back(absl::StrCat("{\"after_frames\": ", change.after_frames,
                                   ", \"state\": ", JsonString(change.state), "}"));
  }
  absl::StrAppend(&json, "  \"state_changes\": [", absl::StrJoin(changes, ", "), "],\n");
  std::vector<std::string> times;
  for (const double ns : summary.slice_time_of_flight_ns) times.push_back(JsonNumber(ns));
  absl::StrAppend(&json, "  \"slice_time_of_flight_ns\": [", absl::StrJoin(times, ", "), "],\n");
  absl::StrAppend(&json, "  \"colour_map\": \"inferno (9-point approximation), NaN = grey ",
                  kNoValueGrey.r, "\",\n");
  absl::StrAppend(&json, "  \"slice_colour_scale\": ",
                  summary.slice_scale > 0.0f ? JsonNumber(summary.slice_scale) : "null", ",\n");
  absl::StrAppend(&json, "  \"cumulative_colour_scale\": ",
                  summary.cumulative_scale > 0.0f ? JsonNumber(summary.cumulative_scale) : "null",
                  ",\n");
  absl::StrAppend(&json, "  \"colour_scale_percentile\": ", JsonNumber(kColourScalePercentile),
                  ",\n");
  if (summary.moment_depth) {
    const ClientSummary::MomentDepth& m = *summary.moment_depth;
    absl::StrAppend(&json, "  \"moment_depth\": {\"bits\": ", m.bits,
                    ", \"near_m\": ", JsonNumber(m.near_m), ", \"far_m\": ", JsonNumber(m.far_m),
                    ", \"sigma_px\": ", JsonNumber(m.sigma_px),
                    ", \"from_returns\": ", m.from_returns ? "true" : "false",
                    ", \"empty_pixels\": ", m.empty_pixels,
                    ", \"virtual_plane_m\": ", JsonNumber(m.virtual_plane_m),
                    ", \"occluded_share\": ", JsonNumber(m.occluded_share), "},\n");
  }
  absl::StrAppend(&json, "  \"files\": ", JsonStrings(summary.files), ",\n");
  absl::StrAppend(&json, "  \"interrupted\": ", summary.interrupted ? "true" : "false", ",\n");
  absl::StrAppend(&json, "  \"stream_error\": ",
                  summary.stream_error.empty() ? "null" : JsonString(summary.stream_error), "\n");
  json += "}\n";
  return json;
}

std::string FormatClientSummary(const ClientSummary& summary) {
  std::string text = absl::StrFormat(
      "%d frames from transientd at %s (%s, %dx%d) in %.2f s: %.1f Hz, %d missed", summary.frames,
      summary.address, summary.source_uri, summary.camera_width, summary.camera_height,
      summary.seconds, summary.rate_hz, summary.frames_missed);
  if (summary.corrupt_frames > 0) {
    absl::StrAppendFormat(&text, ", %d corrupt (dropped)", summary.corrupt_frames);
  }
  if (summary.state_announcements > 0) {
    absl::StrAppendFormat(&text, ", %d state announcements", summary.state_announcements);
  }
  absl::StrAppendFormat(&text, "\nlatency: p50 %.1f ms, p90 %.1f ms, p99 %.1f ms, max %.1f ms",
                        summary.latency.p50_ms, summary.latency.p90_ms, summary.latency.p99_ms,
                        summary.latency.max_ms);
  if (summary.source_counters) {
    std::vector<std::string> counters;
    for (const auto& [name, value] : *summary.source_counters) {
      if (value != 0) counters.push_back(absl::StrCat(name, " ", value));
    }
    if (!counters.empty()) absl::StrAppend(&text, "\nsource: ", absl::StrJoin(counters, ", "));
  }
  if (summary.moment_depth) {
    const ClientSummary::MomentDepth& m = *summary.moment_depth;
    absl::StrAppendFormat(&text,
                          "\nmoment depth map: %d bits, %.3g..%.3g m, sigma %.3g px%s; a virtual "
                          "plane at %.3g m is %.1f%% hidden by the scene",
                          m.bits, m.near_m, m.far_m, m.sigma_px,
                          m.from_returns ? ", from Pisarenko returns" : "", m.virtual_plane_m,
                          100.0 * m.occluded_share);
  }
  absl::StrAppendFormat(&text, "\nwrote %d files to %s", summary.files.size(),
                        summary.output_dir);
  return text;
}

}  // namespace transient::tools
