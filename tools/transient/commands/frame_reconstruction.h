// What `transient reconstruct` computes of each frame of moments, and `transient view` draws of
// moment and capture inputs: the frame pipeline's Solve and products (frame_pipeline.h,
// frame_products.h), range, c_0 and flags, the Pisarenko returns and direct/indirect split,
// MESE density and cumulative at the bins' phases and the bounds of the smoothed density.
#pragma once

#include <optional>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "transient/formats/transient_frame.h"
#include "transient/reconstruct/frame_products.h"
#include "transient/reconstruct/image.h"
#include "transient/reconstruct/reconstructor.h"

namespace transient::tools {

// Which estimate(s) to compute; the range and the flags are MESE's unless only Pisarenko is.
enum class Method { kMese, kPisarenko, kBoth };
absl::string_view MethodName(Method method);  // "mese", "pisarenko", "both"

struct ReconstructionSettings {
  Method method = Method::kBoth;
  SolveOptions solve = {};
  double base_frequency_hz = 0.0;
  double threshold = 0.1;                         // relative threshold of a return
  std::vector<double> phases = {};                // of the density, cumulative and bounds
  std::optional<double> bounds_r = std::nullopt;  // r in (0, 1): the bounds too
};

// The core's products a method needs, and how it ranges.
ProductNeeds NeedsOf(Method method);
ProductOptions OptionsOf(const ReconstructionSettings& settings);

// The products of `settings` a reconstruction of its method holds (the datasets of a
// reconstruction file it writes).
ProductSet AvailableProducts(const ReconstructionSettings& settings);

// Solves `moments` (which must pass MomentImage::Validate) and fills the planes `wanted` of
// `out` (those not wanted, or not available to the method, are emptied), with geometry, order,
// frequency, threshold, phases and bounds_r. NotFound naming the product when a wanted one is
// not available.
absl::Status ReconstructFrame(const MomentImage& moments, const ReconstructionSettings& settings,
                              ProductSet wanted, TransientFrame* out);

}  // namespace transient::tools
