// The product table of transient.v1 and the questions asked of it.
#include "transient/wire/product_registry.h"

#include <cassert>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "transient/reconstruct/moments.h"
#include "transient/reconstruct/units.h"

namespace transient::wire {
namespace {

// Indexed by ImageKind; grouped by product in the order of the enum, so that each product's
// images are one run of this array.
constexpr ImageSpec kImages[] = {
    {ImageKind::kRange, v1::RANGE, "range", ImageIndex::kNone, units::kMetres, 1},
    {ImageKind::kDepth, v1::DEPTH, "depth", ImageIndex::kNone, units::kMetres, 1},
    {ImageKind::kAmplitude, v1::AMPLITUDE, "amplitude", ImageIndex::kNone, units::kSensor, 1},
    {ImageKind::kC0, v1::C0, "c0", ImageIndex::kNone, units::kSensor, 1},
    {ImageKind::kFlags, v1::FLAGS, "flags", ImageIndex::kNone, units::kBits, 1},
    {ImageKind::kCReal, v1::MOMENT_STATE, "c_real", ImageIndex::kHarmonic, units::kSensor, 1},
    {ImageKind::kCImag, v1::MOMENT_STATE, "c_imag", ImageIndex::kHarmonicFromOne, units::kSensor,
     1},
    {ImageKind::kQReal, v1::MOMENT_STATE, "q_real", ImageIndex::kHarmonic, units::kPerSensor, 1},
    {ImageKind::kQImag, v1::MOMENT_STATE, "q_imag", ImageIndex::kHarmonic, units::kPerSensor, 1},
    {ImageKind::kSlice, v1::SLICES, "slices", ImageIndex::kSlice, units::kSensorPerRadian, 1},
    {ImageKind::kCumulative, v1::CUMULATIVE, "cumulative", ImageIndex::kSlice, units::kSensor, 1},
    {ImageKind::kDirect, v1::DIRECT_INDIRECT, "direct", ImageIndex::kNone, units::kSensor, 1},
    {ImageKind::kIndirect, v1::DIRECT_INDIRECT, "indirect", ImageIndex::kNone, units::kSensor, 1},
    {ImageKind::kMomentDepth, v1::MOMENT_DEPTH, "moment_depth", ImageIndex::kNone,
     units::kDimensionless, 4},
    {ImageKind::kConfidence, v1::CONFIDENCE, "confidence", ImageIndex::kNone,
     units::kDimensionless, 1},
};

constexpr std::span<const ImageSpec> ImagesOf(ImageKind first, size_t count) {
  return std::span<const ImageSpec>(kImages).subspan(static_cast<size_t>(first), count);
}

constexpr ProductSpec::Needs kMoments = ProductSpec::Needs::kAllHarmonics;

constexpr ProductSpec kProducts[] = {
    {v1::RANGE, "range", ImagesOf(ImageKind::kRange, 1), EncodingRule::kFloatOrMillimetres},
    {v1::DEPTH, "depth", ImagesOf(ImageKind::kDepth, 1), EncodingRule::kFloatOrMillimetres},
    {v1::AMPLITUDE, "amplitude", ImagesOf(ImageKind::kAmplitude, 1), EncodingRule::kFloat},
    {v1::C0, "c0", ImagesOf(ImageKind::kC0, 1), EncodingRule::kFloat, kMoments},
    {v1::FLAGS, "flags", ImagesOf(ImageKind::kFlags, 1), EncodingRule::kFlags},
    {v1::MOMENT_STATE, "moment_state", ImagesOf(ImageKind::kCReal, 4), EncodingRule::kFloat,
     kMoments},
    {v1::SLICES, "slices", ImagesOf(ImageKind::kSlice, 1), EncodingRule::kFloat, kMoments},
    {v1::CUMULATIVE, "cumulative", ImagesOf(ImageKind::kCumulative, 1), EncodingRule::kFloat,
     kMoments},
    {v1::DIRECT_INDIRECT, "direct_indirect", ImagesOf(ImageKind::kDirect, 2),
     EncodingRule::kFloat, kMoments},
    // Of the depth on any schedule; of the Pisarenko returns (from_returns) only with kMoments.
    {v1::MOMENT_DEPTH, "moment_depth", ImagesOf(ImageKind::kMomentDepth, 1),
     EncodingRule::kMomentDepth},
    {v1::CONFIDENCE, "confidence", ImagesOf(ImageKind::kConfidence, 1), EncodingRule::kFloat,
     ProductSpec::Needs::kHarmonicSet},
};

constexpr EncodingChoice kEncodingChoices[] = {
    {v1::FLOAT32, "float32"},
    {v1::FLOAT16, "float16"},
    {v1::UINT16_MM, "mm"},
};

// The table's own invariants, checked by the compiler: images indexed by kind and grouped by
// product, products in the order of the enum.
constexpr bool TablesAreOrdered() {
  for (size_t i = 0; i < std::size(kImages); ++i) {
    if (static_cast<size_t>(kImages[i].kind) != i) return false;
  }
  for (size_t i = 0; i < std::size(kProducts); ++i) {
    if (static_cast<int>(kProducts[i].product) != static_cast<int>(i) + 1) return false;
    for (const ImageSpec& image : kProducts[i].images) {
      if (image.product != kProducts[i].product) return false;
    }
  }
  return true;
}
static_assert(TablesAreOrdered());
static_assert(std::size(kProducts) == v1::Product_MAX, "a product of the enum has no row");

// How many images of `spec` a frame holds.
int64_t ImageCount(const ImageSpec& spec, int order, int slices) {
  switch (spec.index) {
    case ImageIndex::kNone:
      return 1;
    case ImageIndex::kSlice:
      return slices;
    case ImageIndex::kHarmonic:
      return order + 1;
    case ImageIndex::kHarmonicFromOne:
      return order;
  }
  return 0;
}

std::string ExpectedNames(const ProductSpec& product) {
  std::vector<std::string> names;
  for (const ImageSpec& image : product.images) {
    switch (image.index) {
      case ImageIndex::kNone:
        names.push_back(image.stem);
        break;
      case ImageIndex::kSlice:
        names.push_back(absl::StrCat(image.stem, "/N (N < ", kMaxSlices, ")"));
        break;
      case ImageIndex::kHarmonic:
        names.push_back(absl::StrCat(image.stem, "/J (J = 0..", kMaxOrder, ")"));
        break;
      case ImageIndex::kHarmonicFromOne:
        names.push_back(absl::StrCat(image.stem, "/J (J = 1..", kMaxOrder, ")"));
        break;
    }
  }
  return absl::StrJoin(names, ", ");
}

}  // namespace

std::span<const ProductSpec> Products() { return kProducts; }

const ProductSpec* FindProduct(v1::Product product) {
  for (const ProductSpec& spec : kProducts) {
    if (spec.product == product) return &spec;
  }
  return nullptr;
}

const ProductSpec* FindProduct(absl::string_view name) {
  for (const ProductSpec& spec : kProducts) {
    if (name == spec.name) return &spec;
  }
  return nullptr;
}

std::vector<std::string> ProductNames() {
  std::vector<std::string> names;
  for (const ProductSpec& spec : kProducts) names.push_back(spec.name);
  return names;
}

const ImageSpec& Image(ImageKind kind) {
  assert(static_cast<size_t>(kind) < std::size(kImages));
  return kImages[static_cast<size_t>(kind)];
}

std::string ImageName(ImageKind kind, int index) {
  const ImageSpec& spec = Image(kind);
  if (spec.index == ImageIndex::kNone) return spec.stem;
  return absl::StrCat(spec.stem, "/", index);
}

const char* WireUnit(ImageKind kind, absl::string_view ros_encoding) {
  return ros_encoding == "16UC1" ? units::kMillimetres : Image(kind).unit;
}

absl::StatusOr<ImageRef> ParseImageName(v1::Product product, absl::string_view name) {
  const ProductSpec* spec = FindProduct(product);
  if (spec == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat(
        "image \"", name, "\" of product ", static_cast<int>(product),
        ". Violated constraint: a product of transient.v1 (", absl::StrJoin(ProductNames(), ", "),
        ")"));
  }
  for (const ImageSpec& image : spec->images) {
    absl::string_view rest = name;
    if (rest.substr(0, absl::string_view(image.stem).size()) != image.stem) continue;
    rest.remove_prefix(absl::string_view(image.stem).size());
    if (image.index == ImageIndex::kNone) {
      if (rest.empty()) return ImageRef{.spec = &image, .index = -1};
      continue;
    }
    if (rest.size() < 2 || rest.front() != '/') continue;
    rest.remove_prefix(1);
    // Digits only: SimpleAtoi would also take "+3" and " 3", which no daemon writes.
    if (rest.find_first_not_of("0123456789") != absl::string_view::npos) continue;
    int index = -1;
    if (!absl::SimpleAtoi(rest, &index)) continue;
    const int low = image.index == ImageIndex::kHarmonicFromOne ? 1 : 0;
    const int high = image.index == ImageIndex::kSlice ? kMaxSlices - 1 : kMaxOrder;
    if (index < low || index > high) continue;
    return ImageRef{.spec = &image, .index = index};
  }
  return absl::InvalidArgumentError(absl::StrCat("image \"", name, "\" of product ", spec->name,
                                                 ". Violated constraint: one of ",
                                                 ExpectedNames(*spec)));
}

int64_t PlanesPerFrame(v1::Product product, int order, int slices) {
  const ProductSpec* spec = FindProduct(product);
  if (spec == nullptr) return 0;
  int64_t planes = 0;
  for (const ImageSpec& image : spec->images) {
    planes += ImageCount(image, order, slices) * image.channels;
  }
  return planes;
}

bool SendsEncoding(v1::Product product, absl::string_view ros_encoding) {
  const ProductSpec* spec = FindProduct(product);
  if (spec == nullptr) return false;
  switch (spec->encodings) {
    case EncodingRule::kFloat:
      return ros_encoding == "32FC1" || ros_encoding == "16FC1";
    case EncodingRule::kFloatOrMillimetres:
      return ros_encoding == "32FC1" || ros_encoding == "16FC1" || ros_encoding == "16UC1";
    case EncodingRule::kFlags:
      return ros_encoding == "8UC1";
    case EncodingRule::kMomentDepth:
      return ros_encoding == "16UC4" || ros_encoding == "32FC4";
  }
  return false;
}

std::span<const EncodingChoice> EncodingChoices() { return kEncodingChoices; }

std::optional<v1::Encoding> FindEncoding(absl::string_view name) {
  for (const EncodingChoice& choice : kEncodingChoices) {
    if (name == choice.name) return choice.encoding;
  }
  return std::nullopt;
}

}  // namespace transient::wire
