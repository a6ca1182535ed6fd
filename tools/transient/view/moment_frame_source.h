// Frames of moments reconstructed as they are read (frame_reconstruction.h): what `transient
// view` draws of a moment file or of a capture measured through the frame pipeline, with the
// products `transient reconstruct` would write, and no file in between.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "tools/transient/commands/frame_reconstruction.h"
#include "tools/transient/common/frame_slice.h"
#include "transient/formats/moment_file.h"
#include "transient/formats/transient_frame.h"

namespace transient::tools {

class MomentFrameSource : public TransientFrameSource {
 public:
  // Frames held in memory (a capture's, measured), all of one geometry and order.
  static std::unique_ptr<MomentFrameSource> FromFrames(std::string name,
                                                       std::vector<MomentImage> frames,
                                                       ReconstructionSettings settings);
  // Frames `range` of a moment file, read when asked.
  static std::unique_ptr<MomentFrameSource> FromFile(std::string name, MomentFile file,
                                                     FrameRange range,
                                                     ReconstructionSettings settings);

  const std::string& name() const override { return name_; }
  int64_t frames() const override { return frames_; }
  ImageGeometry geometry() const override { return geometry_; }
  double base_frequency_hz() const override { return settings_.base_frequency_hz; }
  int bins() const override { return static_cast<int>(settings_.phases.size()); }
  ProductSet available() const override { return AvailableProducts(settings_); }
  // Reconstructs frame `frame` each time it is read (the view reads every frame twice: its
  // colour scales first, then the pictures). OutOfRange outside 0..frames()-1, the moment
  // file's DataLoss, NotFound for a product the method does not make.
  absl::Status ReadFrame(int64_t frame, ProductSet wanted, TransientFrame* out) const override;

 private:
  MomentFrameSource(std::string name, ReconstructionSettings settings)
      : name_(std::move(name)), settings_(std::move(settings)) {}

  std::string name_;
  ReconstructionSettings settings_;
  ImageGeometry geometry_;
  int64_t frames_ = 0;
  std::vector<MomentImage> held_;     // FromFrames
  std::optional<MomentFile> file_;    // FromFile
  int64_t first_ = 0;                 // of the file's frames
  mutable MomentImage buffer_;        // a file frame being reconstructed
};

}  // namespace transient::tools
