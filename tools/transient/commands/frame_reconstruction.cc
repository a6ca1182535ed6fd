// One frame of moments solved into the planes a reconstruction holds.
#include "tools/transient/commands/frame_reconstruction.h"

#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "transient/formats/reconstruction_file.h"
#include "transient/formats/reconstruction_reader.h"

namespace transient::tools {
namespace {

bool HasMese(Method method) { return method != Method::kPisarenko; }
bool HasPisarenko(Method method) { return method != Method::kMese; }

}  // namespace

ProductNeeds NeedsOf(Method method) {
  const bool pisarenko = HasPisarenko(method);
  return {.range = true,
          .c0 = true,
          .direct_indirect = pisarenko,
          .pisarenko = pisarenko,
          .pisarenko_range = pisarenko};
}

ProductOptions OptionsOf(const ReconstructionSettings& settings) {
  return {.base_frequency_hz = settings.base_frequency_hz,
          .range_method = HasMese(settings.method) ? RangeMethod::kMese : RangeMethod::kPisarenko,
          .threshold = settings.threshold};
}

ProductSet AvailableProducts(const ReconstructionSettings& settings) {
  ProductSet available =
      Products({Product::kRange, Product::kZerothMoment, Product::kFlags});
  if (HasMese(settings.method) && !settings.phases.empty()) {
    available |= Products({Product::kDensity, Product::kCumulative});
  }
  if (HasPisarenko(settings.method)) {
    available |= Products({Product::kPisarenkoPhase, Product::kPisarenkoWeight,
                           Product::kPisarenkoUniform, Product::kPisarenkoRange,
                           Product::kPisarenkoDirect, Product::kPisarenkoIndirect});
  }
  if (settings.bounds_r.has_value() && !settings.phases.empty()) {
    available |= Products({Product::kBoundsLower, Product::kBoundsUpper});
  }
  return available;
}

absl::Status ReconstructFrame(const MomentImage& moments, const ReconstructionSettings& settings,
                              ProductSet wanted, TransientFrame* out) {
  const ProductSet missing = wanted & ~AvailableProducts(settings);
  if (missing.any()) {
    std::vector<std::string> names;
    for (int p = 0; p < kProductCount; ++p) {
      if (missing[p]) names.push_back(ProductPath(static_cast<Product>(p)));
    }
    return absl::NotFoundError(absl::StrCat("a reconstruction by ", MethodName(settings.method),
                                            " has no ", absl::StrJoin(names, ", ")));
  }
  const auto solved = std::make_shared<SolvedImage>(Solve(moments, settings.solve));
  const std::shared_ptr<const FrameProducts> products =
      ComputeProducts(solved, CameraInfo{}, OptionsOf(settings), NeedsOf(settings.method));
  const auto has = [&](Product product) { return wanted[static_cast<int>(product)]; };
  const auto take = [&](Product product, const std::vector<float>& plane,
                        std::vector<float>* destination) {
    if (has(product)) {
      *destination = plane;
    } else {
      destination->clear();
    }
  };
  *out = TransientFrame{.geometry = moments.geometry,
                        .order = moments.order,
                        .base_frequency_hz = settings.base_frequency_hz,
                        .index = out->index,
                        .threshold = settings.threshold,
                        .phases = settings.phases,
                        .bounds_r = settings.bounds_r};
  take(Product::kRange, products->range_m, &out->range_m);
  take(Product::kZerothMoment, products->c0, &out->c0);
  if (has(Product::kFlags)) out->flags = products->flags;
  if (products->pisarenko != nullptr) {
    take(Product::kPisarenkoPhase, products->pisarenko->phase, &out->pisarenko_phase);
    take(Product::kPisarenkoWeight, products->pisarenko->weight, &out->pisarenko_weight);
    take(Product::kPisarenkoUniform, products->pisarenko->uniform, &out->pisarenko_uniform);
    take(Product::kPisarenkoRange, products->pisarenko_range_m, &out->pisarenko_range_m);
    take(Product::kPisarenkoDirect, products->direct, &out->pisarenko_direct);
    take(Product::kPisarenkoIndirect, products->indirect, &out->pisarenko_indirect);
  }
  const size_t bin_values = settings.phases.size() * static_cast<size_t>(solved->geometry.pixel_count());
  if (has(Product::kDensity)) {
    out->density.resize(bin_values);
    DensitySlices(*solved, settings.phases, out->density);
  }
  if (has(Product::kCumulative)) {
    out->cumulative.resize(bin_values);
    CumulativeSlices(*solved, settings.phases, out->cumulative);
  }
  if (has(Product::kBoundsLower) || has(Product::kBoundsUpper)) {
    out->bounds_lower.resize(bin_values);
    out->bounds_upper.resize(bin_values);
    BoundSlices(*solved, *settings.bounds_r, settings.phases, out->bounds_lower,
                out->bounds_upper);
    if (!has(Product::kBoundsLower)) out->bounds_lower.clear();
    if (!has(Product::kBoundsUpper)) out->bounds_upper.clear();
  }
  return absl::OkStatus();
}

absl::string_view MethodName(Method method) {
  switch (method) {
    case Method::kMese:
      return "mese";
    case Method::kPisarenko:
      return "pisarenko";
    case Method::kBoth:
      return "both";
  }
  return "unknown";
}

}  // namespace transient::tools
