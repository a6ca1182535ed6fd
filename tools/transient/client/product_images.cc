#include "tools/transient/client/product_images.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <span>
#include <system_error>
#include <utility>

#include "absl/algorithm/container.h"
#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "tools/transient/common/image_writers.h"
#include "transient/reconstruct/moment_depth_map.h"
#include "transient/reconstruct/percentile.h"
#include "transient/wire/product_registry.h"

namespace transient::tools {
namespace {

namespace fs = std::filesystem;

using ::transient::client::DecodedImage;

// Writes one group of images of the same product; appends the files to summary->files.
class ProductWriter {
 public:
  ProductWriter(fs::path dir, const std::vector<v1::Product>& requested, ClientSummary* summary,
                std::optional<double> virtual_plane_m = std::nullopt)
      : dir_(std::move(dir)),
        requested_(requested),
        summary_(summary),
        virtual_plane_m_(virtual_plane_m) {}

  absl::Status Write(v1::Product product, const std::vector<const DecodedImage*>& images) {
    const DecodedImage& first = *images.front();
    switch (product) {
      case v1::RANGE:
        if (absl::Status status = Tiff("range.tiff", first); !status.ok()) return status;
        if (!absl::c_linear_search(requested_, v1::DEPTH)) return Millimetres("range_mm.png", first);
        return absl::OkStatus();
      case v1::DEPTH:
        return Millimetres("depth.png", first);
      case v1::AMPLITUDE:
        return Tiff("amplitude.tiff", first);
      case v1::C0:
        return Tiff("c0.tiff", first);
      case v1::FLAGS:
        return Flags("flags.png", first);
      case v1::SLICES:
        return Series("slices", images, &summary_->slice_scale);
      case v1::CUMULATIVE:
        return Series("cumulative", images, &summary_->cumulative_scale);
      case v1::MOMENT_DEPTH:
        return MomentDepth(first);
      default:
        return Planes(ProductStem(product), images);
    }
  }

 private:
  absl::Status Done(const std::string& name, absl::Status status) {
    if (status.ok()) summary_->files.push_back(name);
    return status;
  }

  absl::Status Tiff(const std::string& name, const DecodedImage& image) {
    return Done(name, WriteTiffFloat((dir_ / name).string(), image.geometry, image.values));
  }

  absl::Status Millimetres(const std::string& name, const DecodedImage& image) {
    std::vector<uint16_t> millimetres(image.values.size());
    std::transform(image.values.begin(), image.values.end(), millimetres.begin(),
                   MetresToMillimetres);
    return Done(name, WritePng16((dir_ / name).string(), image.geometry, millimetres));
  }

  absl::Status Flags(const std::string& name, const DecodedImage& image) {
    std::vector<uint8_t> bits(image.values.size());
    std::transform(image.values.begin(), image.values.end(), bits.begin(), [](float value) {
      return std::isfinite(value) ? static_cast<uint8_t>(std::clamp(value, 0.0f, 255.0f)) : 0;
    });
    return Done(name, WritePng8((dir_ / name).string(), image.geometry, bits));
  }

  // The decoded moments b1..b4 as float TIFFs, and the occlusion of the virtual plane.
  absl::Status MomentDepth(const DecodedImage& image) {
    if (!image.moment_depth) return absl::InternalError("moment_depth image without its map");
    const MomentDepthMap& map = *image.moment_depth;
    if (absl::Status status = MakeFolder("moment_depth"); !status.ok()) return status;
    const int64_t pixels = map.geometry.pixel_count();
    std::vector<float> plane(static_cast<size_t>(pixels));
    for (int j = 1; j <= 4; ++j) {
      for (int64_t p = 0; p < pixels; ++p) {
        plane[p] = map.Texel(static_cast<int>(p % map.geometry.width),
                             static_cast<int>(p / map.geometry.width))[j];
      }
      const std::string name = absl::StrCat("moment_depth/b", j, ".tiff");
      if (absl::Status status =
              Done(name, WriteTiffFloat((dir_ / name).string(), map.geometry, plane));
          !status.ok()) {
        return status;
      }
    }
    const double plane_m = virtual_plane_m_.value_or(0.5 * (map.options.normalisation.near_m +
                                                            map.options.normalisation.far_m));
    std::vector<uint8_t> occlusion(static_cast<size_t>(pixels));
    double sum = 0.0;
    for (int64_t p = 0; p < pixels; ++p) {
      const float fraction = map.Occlusion(static_cast<int>(p % map.geometry.width),
                                           static_cast<int>(p / map.geometry.width), plane_m);
      sum += fraction;
      occlusion[p] = static_cast<uint8_t>(std::lround(255.0f * std::clamp(fraction, 0.0f, 1.0f)));
    }
    summary_->moment_depth = ClientSummary::MomentDepth{
        .bits = map.options.format == MomentMapFormat::kOptimized64 ? 64 : 128,
        .near_m = map.options.normalisation.near_m,
        .far_m = map.options.normalisation.far_m,
        .sigma_px = map.options.sigma_px,
        .from_returns = image.moment_depth_from_returns,
        .empty_pixels = map.empty_texels,
        .virtual_plane_m = plane_m,
        .occluded_share = sum / static_cast<double>(pixels)};
    const std::string name = "moment_depth/occlusion_plane.png";
    return Done(name, WritePng8((dir_ / name).string(), map.geometry, occlusion));
  }

  absl::Status MakeFolder(const std::string& folder) {
    std::error_code error;
    fs::create_directories(dir_ / folder, error);
    if (error) {
      return absl::ErrnoToStatus(error.value(),
                                 absl::StrCat((dir_ / folder).string(), ": cannot create"));
    }
    return absl::OkStatus();
  }

  // One colour scale for the whole series, so that brightness compares across slices.
  absl::Status Series(const std::string& folder, const std::vector<const DecodedImage*>& images,
                      float* scale_out) {
    std::vector<float> finite;
    for (const DecodedImage* image : images) {
      std::copy_if(image->values.begin(), image->values.end(), std::back_inserter(finite),
                   [](float value) { return std::isfinite(value); });
    }
    const double percentile = Percentile(std::span<float>(finite), kColourScalePercentile);
    const float scale = percentile > 0.0 && std::isfinite(percentile)
                            ? static_cast<float>(percentile)
                            : 1.0f;
    *scale_out = scale;
    if (absl::Status status = MakeFolder(folder); !status.ok()) return status;
    for (size_t i = 0; i < images.size(); ++i) {
      const std::string name = absl::StrFormat("%s/slice_%03d.png", folder, i);
      const DecodedImage& image = *images[i];
      absl::Status status = WritePngRgb8((dir_ / name).string(), image.geometry,
                                         ColourMapPlane(image.values, scale));
      if (absl::Status done = Done(name, std::move(status)); !done.ok()) return done;
    }
    return absl::OkStatus();
  }

  // Image names come from the network: only [A-Za-z0-9._-] reach the file system.
  static std::string SafeName(const std::string& name) {
    std::string safe = name;
    for (char& c : safe) {
      if (!absl::ascii_isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '-' &&
          c != '_') {
        c = '_';
      }
    }
    return safe;
  }

  absl::Status Planes(const std::string& stem, const std::vector<const DecodedImage*>& images) {
    if (images.size() == 1) return Tiff(stem + ".tiff", *images.front());
    if (absl::Status status = MakeFolder(stem); !status.ok()) return status;
    for (size_t i = 0; i < images.size(); ++i) {
      const std::string name =
          absl::StrFormat("%s/%03d_%s.tiff", stem, i, SafeName(images[i]->name));
      if (absl::Status status = Tiff(name, *images[i]); !status.ok()) return status;
    }
    return absl::OkStatus();
  }

  fs::path dir_;
  const std::vector<v1::Product>& requested_;
  ClientSummary* summary_;
  std::optional<double> virtual_plane_m_;
};

}  // namespace

std::string ProductStem(int product) {
  const wire::ProductSpec* spec = wire::FindProduct(static_cast<v1::Product>(product));
  return spec != nullptr ? spec->name : absl::StrCat("product_", product);
}

absl::Status WriteProductImages(const std::filesystem::path& dir,
                                const std::vector<client::DecodedImage>& images,
                                const std::vector<v1::Product>& requested,
                                std::optional<double> virtual_plane_m, ClientSummary* summary) {
  // Products in the order they arrived, each with its planes in order.
  std::vector<std::pair<v1::Product, std::vector<const DecodedImage*>>> groups;
  for (const DecodedImage& image : images) {
    if (!absl::c_linear_search(requested, image.product)) continue;  // not asked for: not ours to write
    auto group = std::find_if(groups.begin(), groups.end(),
                              [&](const auto& entry) { return entry.first == image.product; });
    if (group == groups.end()) {
      groups.push_back({image.product, {}});
      group = std::prev(groups.end());
    }
    group->second.push_back(&image);
  }
  for (const auto& [product, group] : groups) {
    if (product == v1::SLICES ||
        (product == v1::CUMULATIVE && !absl::c_linear_search(requested, v1::SLICES))) {
      summary->slice_time_of_flight_ns.clear();
      for (const DecodedImage* image : group) {
        summary->slice_time_of_flight_ns.push_back(image->time_of_flight_ns);
      }
    }
  }
  ProductWriter writer(dir, requested, summary, virtual_plane_m);
  for (const auto& [product, group] : groups) {
    if (absl::Status status = writer.Write(product, group); !status.ok()) return status;
  }
  return absl::OkStatus();
}

}  // namespace transient::tools
