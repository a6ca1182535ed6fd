// Validation of planar moment images.
#include "transient/reconstruct/image.h"

#include "absl/strings/str_cat.h"
#include "transient/reconstruct/moments.h"

namespace transient {

MomentImage::MomentImage(ImageGeometry g, int m)
    : geometry(g),
      order(m),
      real(static_cast<size_t>((m + 1) * g.pixel_count()), 0.0f),
      imag(static_cast<size_t>((m + 1) * g.pixel_count()), 0.0f) {}

absl::Status MomentImage::Validate() const {
  if (order < 1 || order > kMaxOrder) {
    return absl::InvalidArgumentError(
        absl::StrCat("order m = ", order, ". Violated constraint: 1 <= m <= ", kMaxOrder));
  }
  if (geometry.width <= 0 || geometry.height <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("geometry ", geometry.width, "x",
                                                   geometry.height,
                                                   ". Violated constraint: width, height > 0"));
  }
  const size_t expected = static_cast<size_t>((order + 1) * geometry.pixel_count());
  if (real.size() != expected || imag.size() != expected) {
    return absl::InvalidArgumentError(absl::StrCat(
        "moment planes hold ", real.size(), " real and ", imag.size(),
        " imaginary values. Violated constraint: both == (m+1)*width*height = ", expected));
  }
  if (!valid.empty() && valid.size() != static_cast<size_t>(geometry.pixel_count())) {
    return absl::InvalidArgumentError(absl::StrCat(
        "valid plane holds ", valid.size(),
        " values. Violated constraint: empty or width*height = ", geometry.pixel_count()));
  }
  if (!flags.empty() && flags.size() != static_cast<size_t>(geometry.pixel_count())) {
    return absl::InvalidArgumentError(absl::StrCat(
        "flags plane holds ", flags.size(),
        " values. Violated constraint: empty or width*height = ", geometry.pixel_count()));
  }
  return absl::OkStatus();
}

}  // namespace transient
