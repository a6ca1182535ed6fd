// The acquisition schedule (acquisition.h) as attributes of an HDF5 group: /schedule of a
// capture, and the root of a calibration file (also embedded as /calibration of a capture).
// Attributes: base_frequency_hz (float64, Hz), order (int64, m), sampling (string:
// "four-bucket", "arccos", "harmonic-cancellation"), phase_steps (int64, n_phi), zeroth (string:
// "pair", "proxy", "estimated"), proxy_frequency_hz (float64, Hz), exposure_s (float64, s),
// takes (int64), buckets (int64, N of N-step sampling; absent = 4), harmonics (string, the
// measured harmonics in capture order, e.g. "10,2,15"; absent = 1..order).
#pragma once

#include <hdf5.h>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "transient/reconstruct/acquisition.h"

namespace transient {

// Writes the eight attributes (replacing attributes of those names). Internal when HDF5 fails;
// FailedPrecondition, writing nothing, for a depth camera's schedule (SamplingScheme::kDepth),
// which no capture or calibration file holds. Reading refuses sampling "depth" the same way
// (ParseSamplingScheme), InvalidArgument.
absl::Status WriteScheduleAttributes(hid_t object, const ScheduleOptions& schedule);

// Whether a missing `takes` is an error: calibration files written before the attribute
// existed imply 1.
enum class TakesAttribute { kRequired, kOptional };

// Reads the eight attributes, each checked on its own (a finite frequency > 0, an integer order
// in 1..kMaxOrder, a known sampling and zeroth name, ...); the caller validates the schedule as
// a whole. InvalidArgument "<where>: attribute <name>: ..." naming the first bad attribute,
// DataLoss when HDF5 cannot read one.
absl::StatusOr<ScheduleOptions> ReadScheduleAttributes(hid_t object, absl::string_view where,
                                                       TakesAttribute takes);

}  // namespace transient
