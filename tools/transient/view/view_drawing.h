// The drawing of one `transient view` run: the plan, the scales, then frame by frame every
// picture into OUT/frame_NNN/ (and the videos into OUT/).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "tools/transient/common/command_hooks.h"
#include "tools/transient/view/view_command.h"
#include "transient/formats/transient_frame.h"
#include "transient/reconstruct/camera_model.h"

namespace transient::tools {

// Checks that the output directory can be made (or is one) without making it: an existing
// non-directory is InvalidArgument, no writable ancestor PermissionDenied.
[[nodiscard]] absl::Status CheckOutputDirectory(const std::string& output_dir);

// Everything after the input is open: the plan (MakeViewPlan), the output directory check and
// the scales (ChooseViewScales) before anything is written, then the pictures frame by frame,
// numbered from `index_offset` (the input's index of the source's frame 0). Fills `summary`.
// `phases`, `input_intrinsics`: as MakeViewPlan.
[[nodiscard]] absl::Status DrawView(const ViewArgs& args, const TransientFrameSource& source,
                                    const std::vector<double>& phases,
                                    std::optional<PinholeIntrinsics> input_intrinsics,
                                    int64_t index_offset, const CommandHooks& hooks,
                                    ViewSummary& summary);

}  // namespace transient::tools
