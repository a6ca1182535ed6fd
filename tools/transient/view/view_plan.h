// What one `transient view` run draws, resolved against its input before anything is written:
// the pictures asked for (or, when none is, everything the input allows), the bins nearest the
// times of flight asked for, the camera's intrinsics and the planes read per frame.
#pragma once

#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "tools/transient/view/view_command.h"
#include "transient/formats/capture_file.h"
#include "transient/formats/transient_frame.h"
#include "transient/reconstruct/camera_model.h"

namespace transient::tools {

struct ViewPlan {
  bool slices = false, cumulative = false, video = false, images = false, point_cloud = false;
  bool moment_depth = false;     // frame_NNN/moment_depth/ (moment_pictures.h)
  bool direct_indirect = false;  // part of images when the input has Pisarenko products
  bool pisarenko_range = false;  // likewise; a daemon sends direct/indirect without it
  std::vector<int> streak_rows;
  std::vector<PixelPosition> pixels;
  std::vector<int> bins;  // bins drawn by slices, cumulative and video
  std::optional<PinholeIntrinsics> intrinsics;
  ProductSet wanted;  // planes read per frame
};


// True when `args` chooses no picture: then everything the input allows is drawn.
bool DrawsEverything(const ViewArgs& args);

// The pinhole intrinsics of a capture's /camera, checked against the image they must place.
[[nodiscard]] absl::StatusOr<PinholeIntrinsics> CaptureIntrinsics(const CaptureReader& capture,
                                                                  ImageGeometry expected);

// Checks what `args` asks for against `source` and resolves it into a plan.
// `phases` are the source's bin phases (rad); `input_intrinsics` the input's own camera, if
// any (--camera overrides it). A picture chosen explicitly that the input cannot give, a tau
// outside one period, a scanline or pixel outside the image, or a point cloud or moment
// pictures without intrinsics is an error (NotFound/OutOfRange/InvalidArgument naming the
// option); "everything" silently leaves out what the input lacks.
[[nodiscard]] absl::StatusOr<ViewPlan> MakeViewPlan(
    const ViewArgs& args, const TransientFrameSource& source, const std::vector<double>& phases,
    std::optional<PinholeIntrinsics> input_intrinsics);

}  // namespace transient::tools
