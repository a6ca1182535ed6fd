// The files `transient client` makes of the last frame's products: one home for their names,
// formats and colour scales (the table is RunClient's, client_command.h).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "tools/transient/client/client_summary.h"
#include "transient/client/decoded_image.h"
#include "transient/v1/transient.pb.h"

namespace transient::tools {

// The slice and cumulative images use this percentile of their finite values as full colour:
// a few hot pixels (a specular return) do not wash out the rest of the sweep.
inline constexpr double kColourScalePercentile = 99.5;

// The folder and file stem of a product: its registry name, or product_<n> for a value the
// registry does not know (a newer daemon's, in GetInfo).
std::string ProductStem(int product);

// Writes the images of the products in `requested` (others are ignored) into `dir`, grouped by
// product in the order they arrived; lists each file in summary->files, and fills the slice
// times of flight, the colour scales and the moment-depth summary (the occlusion of a virtual
// plane at `virtual_plane_m`, default the middle of the map's depth range). Image names come
// from the network: only [A-Za-z0-9._-] reach the file system. Stops at the first file that
// cannot be written (its error, naming the path).
[[nodiscard]] absl::Status WriteProductImages(const std::filesystem::path& dir,
                                              const std::vector<client::DecodedImage>& images,
                                              const std::vector<v1::Product>& requested,
                                              std::optional<double> virtual_plane_m,
                                              ClientSummary* summary);

}  // namespace transient::tools
