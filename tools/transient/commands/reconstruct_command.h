// `transient reconstruct IN.h5 OUT.h5`: reconstructs every frame of a moment file and writes
// the products to a reconstruction file (layouts in docs/formats/). The command
// runs in-process; main.cc only maps its arguments and its status to the command line.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "tools/transient/common/command_hooks.h"
#include "absl/strings/string_view.h"
#include "tools/transient/commands/frame_reconstruction.h"
#include "tools/transient/common/frame_slice.h"
#include "transient/reconstruct/biasing.h"
#include "transient/reconstruct/image.h"
#include "transient/reconstruct/reconstructor.h"

namespace transient::tools {

absl::string_view BiasModeName(BiasMode mode);      // "raise", "scale"
absl::string_view ZerothName(ZerothMoment zeroth);  // "measured", "estimate"

// Parse the option values above; InvalidArgument names the option and the accepted values.
[[nodiscard]] absl::StatusOr<Method> ParseMethod(absl::string_view text);
[[nodiscard]] absl::StatusOr<BiasMode> ParseBiasMode(absl::string_view text);
[[nodiscard]] absl::StatusOr<ZerothMoment> ParseZeroth(absl::string_view text);

inline constexpr int kMinBins = 8;
inline constexpr int kMaxBins = 65536;
// Density, cumulative and bound planes are computed and written a block of bins at a time so
// that memory stays bounded for large images and many bins: 2^22 floats = 16 MiB per buffer.
inline constexpr int64_t kDefaultMaxBlockValues = int64_t{1} << 22;

struct ReconstructArgs {
  std::string input_path = {};   // a `transient-moments 1` file
  std::string output_path = {};  // replaced only when the whole run succeeds
  Method method = Method::kBoth;
  int bins = 256;              // phases 2*pi*n/bins of /density, /cumulative, /bounds
  double bias_epsilon = 4e-3;  // lambda_min(C) >= epsilon * c_0 after biasing (thesis §8.5)
  BiasMode bias_mode = BiasMode::kRaiseZeroth;
  ZerothMoment zeroth = ZerothMoment::kMeasured;
  // Use the input's /moments attribute `zeroth` instead of `zeroth` when the file has it (what
  // `--zeroth` does when it is not given).
  bool zeroth_from_file = false;
  double threshold = 0.1;                         // relative threshold of a return (RangeOptions)
  std::optional<double> bounds_r = std::nullopt;  // r in (0, 1): also write /bounds
  FrameSlice frames = {};                         // default ":" (all frames)
  // Values (bins x pixels) in one block of bins planes; at least one plane is computed at a
  // time whatever this says. Not a command-line option: tests lower it to exercise blocking.
  int64_t max_block_values = kDefaultMaxBlockValues;

  // Checks every option once, as a whole; the message names the option as spelled on the
  // command line, its value and the rule: "--bins = 4: expected an integer in 8..65536".
  absl::Status Validate() const;
};

// What a run did, for the one-line summary.
struct ReconstructSummary {
  std::string output_path = {};
  int64_t frames = 0;
  ImageGeometry geometry = {};
  int order = 0;
  Method method = Method::kBoth;
  int64_t pixels = 0;     // frames * pixel_count
  int64_t biased = 0;     // pixels with kFlagBiased
  int64_t invalid = 0;    // pixels with kFlagInvalidInput
  int64_t no_return = 0;  // pixels with kFlagNoReturn
  double seconds = 0.0;   // wall-clock time of the run
};

// "2 frames of 16x12 px (384 pixels), m=3, both: 99.5% biased, 0.5% invalid, 1.0% no
// return, 0.02 s -> out.h5"
std::string FormatSummary(const ReconstructSummary& summary);

// Runs the command. Bad options or a bad input file fail before any output exists; any
// failure, cancellation included, leaves no output (and no temporary) file behind. Error
// messages name the file, the object and the rule (see MomentFile::Open). Pixel-level
// problems (NaN/Inf, c_0 <= 0, masked pixels) never fail the run: they set /flags bits.
[[nodiscard]] absl::StatusOr<ReconstructSummary> RunReconstruct(const ReconstructArgs& args,
                                                                const CommandHooks& hooks = {});

}  // namespace transient::tools
