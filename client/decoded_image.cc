// DecodeFrame: every image of a frame checked against the product registry, then decoded.
#include "transient/client/decoded_image.h"

#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "transient/wire/image_codec.h"

namespace transient::client {

absl::StatusOr<std::vector<DecodedImage>> DecodeFrame(const v1::Frame& frame) {
  std::vector<DecodedImage> images;
  images.reserve(static_cast<size_t>(frame.images_size()));
  for (const v1::Image& image : frame.images()) {
    const auto data_loss = [&](auto&&... parts) {
      return absl::DataLossError(
          absl::StrCat("image '", image.name(), "' of frame ", frame.sequence(), " ", parts...));
    };
    if (image.width() == 0 || image.height() == 0 || image.width() > kMaxImageSide ||
        image.height() > kMaxImageSide) {
      return data_loss("is ", image.width(), "x", image.height(), " px. Violated constraint: 1..",
                       kMaxImageSide, " px each way");
    }
    absl::StatusOr<wire::ImageRef> ref = wire::ParseImageName(image.product(), image.name());
    if (!ref.ok()) return data_loss("is not an image of its product: ", ref.status().message());
    const wire::ImageSpec& spec = *ref->spec;
    if (!wire::SendsEncoding(image.product(), image.encoding())) {
      return data_loss("has encoding=\"", image.encoding(),
                       "\". Violated constraint: an encoding product ",
                       wire::FindProduct(image.product())->name, " is sent in");
    }
    const absl::string_view wire_unit = wire::WireUnit(spec.kind, image.encoding());
    if (image.unit() != wire_unit) {
      return data_loss("has unit=\"", image.unit(), "\". Violated constraint: \"", wire_unit,
                       "\" for ", image.encoding(), " images of ", spec.stem);
    }
    absl::StatusOr<std::vector<float>> values = wire::DecodeImage(image);
    if (!values.ok()) {
      return absl::DataLossError(
          absl::StrCat("frame ", frame.sequence(), ": ", values.status().message()));
    }
    const ImageGeometry geometry{static_cast<int>(image.width()),
                                 static_cast<int>(image.height())};
    if (static_cast<int64_t>(values->size()) != spec.channels * geometry.pixel_count()) {
      return data_loss("decodes to ", values->size(), " values for ", image.width(), "x",
                       image.height(), " px of ", spec.channels,
                       spec.channels == 1 ? " value" : " values");
    }
    std::optional<MomentDepthMap> moment_depth;
    if (spec.kind == wire::ImageKind::kMomentDepth) {
      absl::StatusOr<MomentDepthMap> map = wire::DecodeMomentDepth(image);
      if (!map.ok()) {
        return absl::DataLossError(
            absl::StrCat("frame ", frame.sequence(), ": ", map.status().message()));
      }
      moment_depth = *std::move(map);
    }
    images.push_back({.name = image.name(),
                      .product = image.product(),
                      .kind = spec.kind,
                      .index = ref->index,
                      .unit = spec.unit,
                      .geometry = geometry,
                      .time_of_flight_ns = image.time_of_flight_ns(),
                      .values = *std::move(values),
                      .moment_depth = std::move(moment_depth),
                      .moment_depth_from_returns = image.moment_depth().from_returns()});
  }
  return images;
}

}  // namespace transient::client
