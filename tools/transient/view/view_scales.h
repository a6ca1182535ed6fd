// The colour scales of one `transient view` run, fixed before the first picture so that every
// frame of a run is drawn on the same scale.
#pragma once

#include "absl/status/statusor.h"
#include "tools/transient/common/command_hooks.h"
#include "tools/transient/view/moment_pictures.h"
#include "tools/transient/view/view_command.h"
#include "tools/transient/view/view_pictures.h"
#include "tools/transient/view/view_plan.h"
#include "transient/formats/transient_frame.h"

namespace transient::tools {

// One pass over the frames to fix every colour scale for the whole run, and the depth
// percentiles of the moment pictures' defaults (`depth`, when the plan draws them).
// Each scale is the kScaleQuantile quantile of at most kMaxScaleSamples values (an even stride);
// --scale fixes the density's. Cancelled between frames.
[[nodiscard]] absl::StatusOr<ViewScales> ChooseViewScales(const ViewArgs& args,
                                                        const TransientFrameSource& source,
                                                        const ViewPlan& plan,
                                                        const CommandHooks& hooks,
                                                        DepthPercentiles* depth);

}  // namespace transient::tools
