// Tests of product_registry.h: one row per product of the enum, names that round trip, image
// names parsed back and malformed ones refused, units, planes per frame and encodings.
#include "transient/wire/product_registry.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

#include "tests/support/status_matchers.h"
#include "transient/reconstruct/moments.h"
#include "transient/reconstruct/units.h"

namespace transient::wire {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

TEST(ProductRegistry, EveryProductOfTheEnumHasOneRowInEnumOrder) {
  std::vector<v1::Product> listed;
  for (const ProductSpec& spec : Products()) listed.push_back(spec.product);
  std::vector<v1::Product> in_enum;
  for (int p = v1::Product_MIN; p <= v1::Product_MAX; ++p) {
    if (v1::Product_IsValid(p) && p != v1::PRODUCT_UNSPECIFIED) {
      in_enum.push_back(static_cast<v1::Product>(p));
    }
  }
  EXPECT_EQ(listed, in_enum);
  EXPECT_EQ(FindProduct(v1::PRODUCT_UNSPECIFIED), nullptr);
  EXPECT_EQ(FindProduct(static_cast<v1::Product>(42)), nullptr);
}

TEST(ProductRegistry, NamesAreTheCommandLineNamesAndFindTheirProduct) {
  EXPECT_THAT(ProductNames(),
              ElementsAre("range", "depth", "amplitude", "c0", "flags", "moment_state", "slices",
                          "cumulative", "direct_indirect", "moment_depth", "confidence"));
  for (const ProductSpec& spec : Products()) {
    ASSERT_NE(FindProduct(spec.name), nullptr) << spec.name;
    EXPECT_EQ(FindProduct(spec.name)->product, spec.product);
    EXPECT_EQ(FindProduct(spec.product), &spec);
  }
  EXPECT_EQ(FindProduct("RANGE"), nullptr);  // enum names are not command-line names
  EXPECT_EQ(FindProduct(""), nullptr);
}

TEST(ProductRegistry, EveryImageKindBelongsToExactlyOneProduct) {
  std::set<ImageKind> seen;
  std::set<std::string> stems;
  for (const ProductSpec& spec : Products()) {
    ASSERT_FALSE(spec.images.empty()) << spec.name;
    for (const ImageSpec& image : spec.images) {
      EXPECT_EQ(image.product, spec.product) << image.stem;
      EXPECT_EQ(&Image(image.kind), &image) << image.stem;
      EXPECT_TRUE(seen.insert(image.kind).second) << image.stem;
      EXPECT_TRUE(stems.insert(image.stem).second) << image.stem;
    }
  }
  EXPECT_EQ(seen.size(), static_cast<size_t>(ImageKind::kConfidence) + 1);
}

TEST(ProductRegistry, ImagesAreNamedAsTheProtocolSays) {
  EXPECT_EQ(ImageName(ImageKind::kRange), "range");
  EXPECT_EQ(ImageName(ImageKind::kRange, 7), "range");  // no index: ignored
  EXPECT_EQ(ImageName(ImageKind::kSlice, 12), "slices/12");
  EXPECT_EQ(ImageName(ImageKind::kCumulative, 0), "cumulative/0");
  EXPECT_EQ(ImageName(ImageKind::kQReal, 2), "q_real/2");
  EXPECT_EQ(ImageName(ImageKind::kCImag, 1), "c_imag/1");
  EXPECT_EQ(ImageName(ImageKind::kDirect), "direct");
  EXPECT_EQ(ImageName(ImageKind::kIndirect), "indirect");
  EXPECT_EQ(ImageName(ImageKind::kMomentDepth), "moment_depth");
}

TEST(ProductRegistry, ImageNamesParseBackToTheirKindAndIndex) {
  for (const ProductSpec& spec : Products()) {
    for (const ImageSpec& image : spec.images) {
      const std::vector<int> indices =
          image.index == ImageIndex::kNone              ? std::vector<int>{-1}
          : image.index == ImageIndex::kSlice           ? std::vector<int>{0, 5, kMaxSlices - 1}
          : image.index == ImageIndex::kHarmonicFromOne ? std::vector<int>{1, kMaxOrder}
                                                        : std::vector<int>{0, 3, kMaxOrder};
      for (int index : indices) {
        const std::string name = ImageName(image.kind, index);
        SCOPED_TRACE(name);
        const absl::StatusOr<ImageRef> parsed = ParseImageName(spec.product, name);
        ASSERT_THAT(parsed.status(), IsOk());
        EXPECT_EQ(parsed->spec, &image);
        EXPECT_EQ(parsed->index, index);
      }
    }
  }
}

TEST(ProductRegistry, MalformedImageNamesAreRefusedNamingTheExpectedOnes) {
  const std::vector<std::string> bad_slices = {"slices",    "slices/",   "slices/-1",
                                               "slices/+3", "slices/ 3", "slices/1024",
                                               "slices/3x", "slice/3",   "cumulative/3",
                                               "slices//3", "slices/99999999999999999999"};
  for (const std::string& name : bad_slices) {
    EXPECT_THAT(ParseImageName(v1::SLICES, name).status(),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         AllOf(HasSubstr("\"" + name + "\""), HasSubstr("of product slices"),
                               HasSubstr("slices/N (N < 1024)"))));
  }
  EXPECT_THAT(ParseImageName(v1::MOMENT_STATE, "c_imag/0").status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("c_real/J (J = 0..16), c_imag/J (J = 1..16), q_real/J")));
  EXPECT_THAT(ParseImageName(v1::MOMENT_STATE, "q_real/17").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("Violated constraint")));
  EXPECT_THAT(ParseImageName(v1::RANGE, "range/0").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("one of range")));
  EXPECT_THAT(ParseImageName(v1::RANGE, "depth").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("Violated constraint")));
  EXPECT_THAT(ParseImageName(v1::DIRECT_INDIRECT, "directindirect").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("one of direct, indirect")));
  EXPECT_THAT(ParseImageName(static_cast<v1::Product>(42), "range").status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("of product 42")));
}

TEST(ProductRegistry, UnitsAreTheCoreSpellings) {
  EXPECT_STREQ(Image(ImageKind::kRange).unit, units::kMetres);
  EXPECT_STREQ(Image(ImageKind::kDepth).unit, "m");
  EXPECT_STREQ(Image(ImageKind::kAmplitude).unit, "sensor");
  EXPECT_STREQ(Image(ImageKind::kFlags).unit, "bits");
  EXPECT_STREQ(Image(ImageKind::kCReal).unit, "sensor");
  EXPECT_STREQ(Image(ImageKind::kQImag).unit, "1/sensor");
  EXPECT_STREQ(Image(ImageKind::kSlice).unit, "sensor/rad");
  EXPECT_STREQ(Image(ImageKind::kCumulative).unit, "sensor");
  EXPECT_STREQ(Image(ImageKind::kIndirect).unit, "sensor");
  EXPECT_STREQ(Image(ImageKind::kMomentDepth).unit, "1");
  // Millimetres on the wire, metres once decoded.
  EXPECT_STREQ(WireUnit(ImageKind::kDepth, "16UC1"), "mm");
  EXPECT_STREQ(WireUnit(ImageKind::kDepth, "32FC1"), "m");
  EXPECT_STREQ(WireUnit(ImageKind::kSlice, "16FC1"), "sensor/rad");
}

TEST(ProductRegistry, PlanesPerFrameCountTheImagesAFrameHoldsTimesTheirChannels) {
  constexpr int kOrder = 3;
  constexpr int kSlices = 64;
  EXPECT_EQ(PlanesPerFrame(v1::RANGE, kOrder, kSlices), 1);
  EXPECT_EQ(PlanesPerFrame(v1::FLAGS, kOrder, kSlices), 1);
  // m = 3: 4 c_real, 3 c_imag, 4 q_real, 4 q_imag (as the daemon sends them).
  EXPECT_EQ(PlanesPerFrame(v1::MOMENT_STATE, kOrder, kSlices), 15);
  EXPECT_EQ(PlanesPerFrame(v1::SLICES, kOrder, kSlices), 64);
  EXPECT_EQ(PlanesPerFrame(v1::CUMULATIVE, kOrder, 8), 8);
  EXPECT_EQ(PlanesPerFrame(v1::DIRECT_INDIRECT, kOrder, kSlices), 2);
  EXPECT_EQ(PlanesPerFrame(v1::MOMENT_DEPTH, kOrder, kSlices), 4);  // one image of 4 channels
  EXPECT_EQ(PlanesPerFrame(v1::PRODUCT_UNSPECIFIED, kOrder, kSlices), 0);
}

TEST(ProductRegistry, EncodingsFollowTheProductsRule) {
  for (const char* encoding : {"32FC1", "16FC1", "16UC1"}) {
    EXPECT_TRUE(SendsEncoding(v1::RANGE, encoding)) << encoding;
    EXPECT_TRUE(SendsEncoding(v1::DEPTH, encoding)) << encoding;
  }
  EXPECT_TRUE(SendsEncoding(v1::SLICES, "16FC1"));
  EXPECT_FALSE(SendsEncoding(v1::SLICES, "16UC1"));  // millimetres only for lengths
  EXPECT_FALSE(SendsEncoding(v1::AMPLITUDE, "16UC1"));
  EXPECT_TRUE(SendsEncoding(v1::FLAGS, "8UC1"));
  EXPECT_FALSE(SendsEncoding(v1::FLAGS, "32FC1"));
  EXPECT_FALSE(SendsEncoding(v1::RANGE, "8UC1"));
  EXPECT_TRUE(SendsEncoding(v1::MOMENT_DEPTH, "16UC4"));
  EXPECT_TRUE(SendsEncoding(v1::MOMENT_DEPTH, "32FC4"));
  EXPECT_FALSE(SendsEncoding(v1::MOMENT_DEPTH, "32FC1"));
  EXPECT_FALSE(SendsEncoding(v1::RANGE, "32FC4"));
  EXPECT_FALSE(SendsEncoding(static_cast<v1::Product>(42), "32FC1"));
}

TEST(ProductRegistry, EncodingChoicesAreTheClientsNames) {
  std::vector<std::string> names;
  for (const EncodingChoice& choice : EncodingChoices()) names.push_back(choice.name);
  EXPECT_THAT(names, ElementsAre("float32", "float16", "mm"));
  EXPECT_EQ(FindEncoding("float16"), v1::FLOAT16);
  EXPECT_EQ(FindEncoding("mm"), v1::UINT16_MM);
  EXPECT_EQ(FindEncoding("float64"), std::nullopt);
  EXPECT_EQ(FindEncoding("UINT16_MM"), std::nullopt);
}

}  // namespace
}  // namespace transient::wire
