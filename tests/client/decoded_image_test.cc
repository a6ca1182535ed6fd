// decoded_image.h: images encoded as the daemon encodes them come back with their kind, index
// and SI unit; an image its product does not send (name, encoding, unit, size) or whose data
// does not decode is DataLoss naming the image and the frame.
#include "transient/client/decoded_image.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "tests/support/status_matchers.h"
#include "transient/wire/image_codec.h"
#include "transient/wire/product_registry.h"

namespace transient::client {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

constexpr ImageGeometry kSensor{.width = 5, .height = 3};
constexpr wire::PixelRect kWhole{.x = 0, .y = 0, .width = 5, .height = 3};

// A plane of lengths 1.000, 1.001, ... m.
std::vector<float> Lengths() {
  std::vector<float> values(kSensor.pixel_count());
  for (size_t i = 0; i < values.size(); ++i) values[i] = 1.0f + 0.001f * static_cast<float>(i);
  return values;
}

// Adds an image of `kind` as the daemon sends it (name, product and unit from the registry).
v1::Image* AddImage(wire::ImageKind kind, int index, v1::Encoding encoding, v1::Frame* frame) {
  v1::Image* image = frame->add_images();
  EXPECT_THAT(wire::EncodeFloatPlane(Lengths(), kSensor, kWhole, encoding, v1::COMPRESSION_NONE,
                                     image),
              IsOk());
  image->set_name(wire::ImageName(kind, index));
  image->set_product(wire::Image(kind).product);
  image->set_unit(wire::WireUnit(kind, image->encoding()));
  return image;
}

TEST(DecodeFrame, ImagesComeBackWithTheirKindIndexAndSiUnit) {
  v1::Frame frame;
  frame.set_sequence(7);
  AddImage(wire::ImageKind::kDepth, 0, v1::UINT16_MM, &frame);
  AddImage(wire::ImageKind::kSlice, 3, v1::FLOAT32, &frame)->set_time_of_flight_ns(4.5);
  AddImage(wire::ImageKind::kCImag, 2, v1::FLOAT16, &frame);
  const absl::StatusOr<std::vector<DecodedImage>> images = DecodeFrame(frame);
  ASSERT_THAT(images.status(), IsOk());
  ASSERT_EQ(images->size(), 3u);

  const DecodedImage& depth = (*images)[0];
  EXPECT_EQ(depth.name, "depth");
  EXPECT_EQ(depth.product, v1::DEPTH);
  EXPECT_EQ(depth.kind, wire::ImageKind::kDepth);
  EXPECT_EQ(depth.index, -1);
  EXPECT_EQ(depth.unit, "m");  // 16UC1 millimetres on the wire, metres here
  EXPECT_EQ(depth.geometry, kSensor);
  constexpr float kMillimetre = 1e-3f;  // the precision of 16UC1
  const std::vector<float> lengths = Lengths();
  for (size_t i = 0; i < lengths.size(); ++i) {
    EXPECT_NEAR(depth.values[i], lengths[i], 0.5f * kMillimetre + 1e-6f) << i;
  }

  const DecodedImage& slice = (*images)[1];
  EXPECT_EQ(slice.kind, wire::ImageKind::kSlice);
  EXPECT_EQ(slice.index, 3);
  EXPECT_EQ(slice.unit, "sensor/rad");
  EXPECT_EQ(slice.time_of_flight_ns, 4.5);
  EXPECT_EQ(slice.values, lengths);  // float32: exact

  const DecodedImage& moment = (*images)[2];
  EXPECT_EQ(moment.product, v1::MOMENT_STATE);
  EXPECT_EQ(moment.kind, wire::ImageKind::kCImag);
  EXPECT_EQ(moment.index, 2);
  EXPECT_EQ(moment.unit, "sensor");
}

TEST(DecodeFrame, AnImageItsProductDoesNotSendIsDataLossNamingImageAndFrame) {
  struct Case {
    const char* what;
    void (*spoil)(v1::Image*);
    const char* message;
  };
  const Case cases[] = {
      {"a name of another product", [](v1::Image* i) { i->set_name("depth"); },
       "is not an image of its product"},
      {"an index on a single image", [](v1::Image* i) { i->set_name("range/0"); },
       "one of range"},
      {"an unknown product", [](v1::Image* i) { i->set_product(static_cast<v1::Product>(42)); },
       "of product 42"},
      {"millimetres said of floats", [](v1::Image* i) { i->set_unit("mm"); },
       "unit=\"mm\". Violated constraint: \"m\" for 32FC1 images of range"},
      {"no unit", [](v1::Image* i) { i->set_unit(""); }, "unit=\"\""},
      {"an encoding of flags", [](v1::Image* i) { i->set_encoding("8UC1"); },
       "encoding=\"8UC1\". Violated constraint: an encoding product range is sent in"},
      {"no pixels", [](v1::Image* i) { i->set_width(0); }, "is 0x3 px"},
      {"wider than a sensor", [](v1::Image* i) { i->set_width(kMaxImageSide + 1); },
       "is 32769x3 px"},
      {"truncated data", [](v1::Image* i) { i->mutable_data()->resize(7); },
       "data holds 7 bytes"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    v1::Frame frame;
    frame.set_sequence(11);
    AddImage(wire::ImageKind::kRange, 0, v1::FLOAT32, &frame);  // a good one first
    c.spoil(AddImage(wire::ImageKind::kRange, 0, v1::FLOAT32, &frame));
    EXPECT_THAT(DecodeFrame(frame).status(),
                StatusIs(absl::StatusCode::kDataLoss,
                         AllOf(HasSubstr("frame 11"), HasSubstr("range"), HasSubstr(c.message))));
  }
}

TEST(DecodeFrame, MillimetresOfAProductThatIsNoLengthAreDataLoss) {
  v1::Frame frame;
  v1::Image* image = AddImage(wire::ImageKind::kAmplitude, 0, v1::UINT16_MM, &frame);
  EXPECT_EQ(image->unit(), "mm");
  EXPECT_THAT(DecodeFrame(frame).status(),
              StatusIs(absl::StatusCode::kDataLoss,
                       HasSubstr("encoding=\"16UC1\". Violated constraint: an encoding product "
                                 "amplitude is sent in")));
}

TEST(DecodeFrame, AFrameWithoutImagesDecodesToNone) {
  v1::Frame frame;
  frame.set_state(v1::RECONNECTING);
  const absl::StatusOr<std::vector<DecodedImage>> images = DecodeFrame(frame);
  ASSERT_THAT(images.status(), IsOk());
  EXPECT_TRUE(images->empty());
}

}  // namespace
}  // namespace transient::client
