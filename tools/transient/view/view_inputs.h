// The file inputs of `transient view` as frame sources: a reconstruction file read as it is
// (a window of its frames), a moment or capture file reconstructed frame by frame as drawn.
// (A daemon input is DaemonFrameSource.)
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "tools/transient/common/command_hooks.h"
#include "tools/transient/common/frame_slice.h"
#include "tools/transient/view/moment_frame_source.h"
#include "tools/transient/view/view_command.h"
#include "transient/formats/reconstruction_reader.h"
#include "transient/formats/transient_frame.h"
#include "transient/reconstruct/camera_model.h"

namespace transient::tools {

// A window of `range` onto the reader, so that the drawing sees only the frames drawn.
class ReconstructionWindow : public TransientFrameSource {
 public:
  ReconstructionWindow(const ReconstructionReader& reader, FrameRange range, std::string name)
      : reader_(reader), range_(range), name_(std::move(name)) {}
  const std::string& name() const override { return name_; }
  int64_t frames() const override { return range_.count; }
  ImageGeometry geometry() const override { return reader_.geometry(); }
  double base_frequency_hz() const override { return reader_.base_frequency_hz(); }
  int bins() const override { return reader_.bins(); }
  ProductSet available() const override { return reader_.available(); }
  absl::Status ReadFrame(int64_t frame, ProductSet wanted,
                         TransientFrame* out) const override {
    return reader_.ReadFrame(range_.first + frame, wanted, out);
  }

 private:
  const ReconstructionReader& reader_;
  FrameRange range_;
  std::string name_;
};

// A moment or capture input, reconstructed frame by frame as it is drawn.
struct MomentInput {
  std::unique_ptr<MomentFrameSource> source = nullptr;
  std::vector<double> phases = {};
  std::optional<PinholeIntrinsics> intrinsics = std::nullopt;  // a capture's camera
  int64_t first_index = 0;                                     // index in the input of frame 0
};

// The frames --frames selects of a moment file, reconstructed as `transient reconstruct` does by
// default, with the view's --bins and --bounds-r.
[[nodiscard]] absl::StatusOr<MomentInput> OpenMomentInput(const ViewArgs& args);

// A capture is measured through the frame pipeline (its moments held in memory, a few floats a
// pixel per frame), then reconstructed frame by frame as drawn. Without an embedded calibration
// it needs --calibration (InvalidArgument). Cancelled with nothing written.
[[nodiscard]] absl::StatusOr<MomentInput> MeasureCaptureInput(const ViewArgs& args,
                                                              const CommandHooks& hooks);

}  // namespace transient::tools
