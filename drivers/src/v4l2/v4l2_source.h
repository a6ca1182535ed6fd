// The V4L2 capture source, "v4l2:/dev/videoN?key=value&...": a raw-phase ToF sensor through
// the kernel's video capture interface (../shared/research/v4l2.md §5).
//
// The acquisition schedule is the one of thesis §8.3 that such sensors can take: four-bucket
// sampling (one phase step per raw frame, the sensor's "phase sequence"), harmonics j = 1..m of
// a base frequency f, the zeroth moment estimated or measured as a low-frequency proxy. Each
// group of four buckets at one frequency is one sensor sequence. Profiles:
//   mlx7502x: the proposed ToF controls (TOF Frequency Modulation, TOF Phase Sequence, TOF Time
//             Integration; found by ID, else by name, research §1.1, §5.3) and the camera
//             trigger. Before every sequence the source sets the frequency j*f, the phases and
//             the integration times, reads them back, and presses the trigger (internal-trigger
//             mode); the frames are stamped with the read-back values. At the end of a sequence
//             the controls are read back again: a sequence whose controls changed meanwhile
//             (another program) is dropped and the schedule is set again. Samples are signed
//             12-bit A - B.
//   generic:  no controls are touched: the sensor runs the schedule the URI describes, one
//             cycle after another, in its order (for each take: the proxy's buckets if any,
//             then harmonics 1..m, each with the buckets in `phases` order). Frames are stamped
//             from the URI.
// Buffers become sequences by the alignment rule of sequence_assembler.h; a sequence with a
// missing, flagged, short or late buffer is dropped whole and counted (Counters()).
#pragma once

#include <memory>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "transient/drivers/capture_source.h"

namespace transient::v4l2 {

// Opens the source: the device, its format, the controls (read back), and the schedule built
// from the read-back values. InvalidArgument naming the key, value or control that is wrong
// (a frequency the driver sets to other than j*f within 1e-6, a missing control, an adjusted
// format); NotFound / PermissionDenied / Unavailable when the node cannot be opened.
absl::StatusOr<std::unique_ptr<CaptureSource>> OpenV4l2Source(absl::string_view uri);

}  // namespace transient::v4l2
