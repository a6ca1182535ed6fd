// Tests of image_codec.h: ROI resolution, product/encoding checks, round trips of every
// encoding with and without zstd, half-float bit patterns, and decoding of corrupt images.
#include "transient/wire/image_codec.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <zstd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "tests/support/status_matchers.h"

namespace transient::wire {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

// Deliberately odd and non-square, like a real ToF sensor (not a power of two).
constexpr ImageGeometry kSensor{.width = 163, .height = 120};
constexpr float kInf = std::numeric_limits<float>::infinity();

v1::Roi MakeRoi(uint32_t x, uint32_t y, uint32_t width, uint32_t height) {
  v1::Roi roi;
  roi.set_x(x);
  roi.set_y(y);
  roi.set_width(width);
  roi.set_height(height);
  return roi;
}

// ---------------------------------------------------------------------------------------------
// ResolveRoi

TEST(ResolveRoi, ZeroSizeIsTheWholeSensor) {
  const absl::StatusOr<PixelRect> rect = ResolveRoi(MakeRoi(0, 0, 0, 0), kSensor);
  ASSERT_THAT(rect.status(), IsOk());
  EXPECT_EQ(*rect, (PixelRect{.x = 0, .y = 0, .width = 163, .height = 120}));
}

TEST(ResolveRoi, RectangleInsideIsKept) {
  const absl::StatusOr<PixelRect> rect = ResolveRoi(MakeRoi(10, 20, 30, 40), kSensor);
  ASSERT_THAT(rect.status(), IsOk());
  EXPECT_EQ(*rect, (PixelRect{.x = 10, .y = 20, .width = 30, .height = 40}));
  EXPECT_EQ(rect->pixel_count(), 1200);
}

TEST(ResolveRoi, RectangleTouchingTheFarCornerIsInside) {
  const absl::StatusOr<PixelRect> rect = ResolveRoi(MakeRoi(162, 119, 1, 1), kSensor);
  ASSERT_THAT(rect.status(), IsOk());
  EXPECT_EQ(*rect, (PixelRect{.x = 162, .y = 119, .width = 1, .height = 1}));
  EXPECT_THAT(ResolveRoi(MakeRoi(0, 0, 163, 120), kSensor).status(), IsOk());
}

TEST(ResolveRoi, EmptyInOneDimensionIsRejected) {
  EXPECT_THAT(ResolveRoi(MakeRoi(0, 0, 0, 5), kSensor).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("roi"), HasSubstr("width=0"), HasSubstr("163x120"))));
  EXPECT_THAT(ResolveRoi(MakeRoi(3, 4, 5, 0), kSensor).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("roi"), HasSubstr("height=0"), HasSubstr("163x120"))));
}

TEST(ResolveRoi, OffsetWithoutSizeIsRejectedRatherThanGuessed) {
  EXPECT_THAT(ResolveRoi(MakeRoi(5, 0, 0, 0), kSensor).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("x=5")));
  EXPECT_THAT(ResolveRoi(MakeRoi(0, 7, 0, 0), kSensor).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("y=7")));
}

TEST(ResolveRoi, RectangleReachingOutsideIsRejectedNamingFieldValueAndSensor) {
  EXPECT_THAT(ResolveRoi(MakeRoi(200, 0, 10, 10), kSensor).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("roi: x=200 + width=10 reaches outside the 163x120 sensor")));
  // One pixel past the right and the bottom edge.
  EXPECT_THAT(ResolveRoi(MakeRoi(154, 0, 10, 10), kSensor).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("x=154 + width=10")));
  EXPECT_THAT(ResolveRoi(MakeRoi(0, 111, 10, 10), kSensor).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("y=111 + height=10")));
  // Starting just past the edge.
  EXPECT_THAT(ResolveRoi(MakeRoi(163, 0, 1, 1), kSensor).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("x=163")));
  EXPECT_THAT(ResolveRoi(MakeRoi(0, 120, 1, 1), kSensor).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("y=120")));
  // Larger than the sensor from the origin.
  EXPECT_THAT(ResolveRoi(MakeRoi(0, 0, 164, 1), kSensor).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("width=164")));
  EXPECT_THAT(ResolveRoi(MakeRoi(0, 0, 1, 121), kSensor).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("height=121")));
}

TEST(ResolveRoi, ValuesThatWouldOverflowA32BitSumAreRejected) {
  // x + width wraps to 0 in uint32 and to a negative number in int32.
  constexpr uint32_t kMax = std::numeric_limits<uint32_t>::max();
  EXPECT_THAT(ResolveRoi(MakeRoi(kMax, 0, 1, 1), kSensor).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("x=4294967295")));
  EXPECT_THAT(ResolveRoi(MakeRoi(1, 0, kMax, 1), kSensor).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("width=4294967295")));
  EXPECT_THAT(ResolveRoi(MakeRoi(0, kMax, 1, 2), kSensor).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("y=4294967295")));
  EXPECT_THAT(ResolveRoi(MakeRoi(0, 0x80000000u, 1, 0x80000000u), kSensor).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("reaches outside")));
  EXPECT_THAT(ResolveRoi(MakeRoi(kMax, kMax, kMax, kMax), kSensor).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("reaches outside")));
}

TEST(ResolveRoi, EmptySensorIsRejected) {
  EXPECT_THAT(ResolveRoi(MakeRoi(0, 0, 0, 0), ImageGeometry{.width = 0, .height = 120}).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("sensor 0x120")));
}

// ---------------------------------------------------------------------------------------------
// CheckEncoding, EncodingName

TEST(CheckEncoding, MillimetresOnlyForLengthsAndFlagsAndMomentDepthAcceptAnything) {
  const std::vector<v1::Product> products = {
      v1::RANGE,        v1::DEPTH,  v1::AMPLITUDE,  v1::C0,          v1::FLAGS,
      v1::MOMENT_STATE, v1::SLICES, v1::CUMULATIVE, v1::DIRECT_INDIRECT, v1::MOMENT_DEPTH, v1::CONFIDENCE};
  const std::vector<v1::Encoding> encodings = {v1::ENCODING_UNSPECIFIED, v1::FLOAT32,
                                               v1::FLOAT16, v1::UINT16_MM};
  ASSERT_EQ(products.size(), static_cast<size_t>(v1::Product_ARRAYSIZE - 1));
  ASSERT_EQ(encodings.size(), static_cast<size_t>(v1::Encoding_ARRAYSIZE));
  for (v1::Product product : products) {
    for (v1::Encoding encoding : encodings) {
      SCOPED_TRACE(v1::Product_Name(product) + " as " + v1::Encoding_Name(encoding));
      const bool allowed = encoding != v1::UINT16_MM || product == v1::RANGE ||
                           product == v1::DEPTH || product == v1::FLAGS ||
                           product == v1::MOMENT_DEPTH;
      if (allowed) {
        EXPECT_THAT(CheckEncoding(product, encoding), IsOk());
      } else {
        EXPECT_THAT(CheckEncoding(product, encoding),
                    StatusIs(absl::StatusCode::kInvalidArgument,
                             AllOf(HasSubstr(v1::Product_Name(product)), HasSubstr("UINT16_MM"))));
      }
    }
  }
}

TEST(CheckEncoding, UnknownProductOrEncodingIsRejected) {
  EXPECT_THAT(CheckEncoding(v1::PRODUCT_UNSPECIFIED, v1::FLOAT32),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("PRODUCT_UNSPECIFIED")));
  EXPECT_THAT(CheckEncoding(static_cast<v1::Product>(42), v1::FLOAT32),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("42")));
  EXPECT_THAT(CheckEncoding(v1::RANGE, static_cast<v1::Encoding>(7)),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("encoding=7"), HasSubstr("RANGE"))));
  EXPECT_THAT(CheckEncoding(v1::FLAGS, static_cast<v1::Encoding>(7)),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("encoding=7")));
}

TEST(EncodingName, IsTheRosEncodingString) {
  EXPECT_STREQ(EncodingName(v1::ENCODING_UNSPECIFIED), "32FC1");
  EXPECT_STREQ(EncodingName(v1::FLOAT32), "32FC1");
  EXPECT_STREQ(EncodingName(v1::FLOAT16), "16FC1");
  EXPECT_STREQ(EncodingName(v1::UINT16_MM), "16UC1");
}

// ---------------------------------------------------------------------------------------------
// Half floats

TEST(FloatToHalf, KnownBitPatterns) {
  EXPECT_EQ(FloatToHalf(0.0f), 0x0000);
  EXPECT_EQ(FloatToHalf(-0.0f), 0x8000);
  EXPECT_EQ(FloatToHalf(1.0f), 0x3C00);
  EXPECT_EQ(FloatToHalf(-2.0f), 0xC000);
  EXPECT_EQ(FloatToHalf(0.5f), 0x3800);
  EXPECT_EQ(FloatToHalf(65504.0f), 0x7BFF);   // largest finite half
  EXPECT_EQ(FloatToHalf(0x1p-14f), 0x0400);   // smallest normal half
  EXPECT_EQ(FloatToHalf(0x3FFp-24f), 0x03FF); // largest subnormal half
  EXPECT_EQ(FloatToHalf(0x1p-24f), 0x0001);   // smallest subnormal half
  // 1e-7 / 2^-24 = 1.68 units of the smallest subnormal: rounds to 2.
  EXPECT_EQ(FloatToHalf(1e-7f), 0x0002);
  EXPECT_EQ(FloatToHalf(-1e-7f), 0x8002);
  EXPECT_EQ(FloatToHalf(1e-9f), 0x0000);      // underflows to zero
  EXPECT_EQ(FloatToHalf(0x1p-130f), 0x0000);  // float subnormal
  EXPECT_EQ(FloatToHalf(kInf), 0x7C00);
  EXPECT_EQ(FloatToHalf(-kInf), 0xFC00);
  EXPECT_EQ(FloatToHalf(1e6f), 0x7C00);       // overflows to infinity
  EXPECT_EQ(FloatToHalf(-1e6f), 0xFC00);
}

TEST(FloatToHalf, RoundsTiesToEven) {
  // Normal range: between 1 and 1 + 2^-10 the tie 1 + 2^-11 goes to the even 0x3C00; between
  // 0x3C01 and 0x3C02 the tie goes up to 0x3C02.
  EXPECT_EQ(FloatToHalf(1.0f + 0x1p-11f), 0x3C00);
  EXPECT_EQ(FloatToHalf(1.0f + 3 * 0x1p-11f), 0x3C02);
  EXPECT_EQ(FloatToHalf(1.0f + 0x1p-11f + 0x1p-20f), 0x3C01);  // just above the tie
  EXPECT_EQ(FloatToHalf(1.0f + 0x1p-11f - 0x1p-20f), 0x3C00);  // just below it
  // The carry out of the mantissa moves to the next binade: 2 - 2^-12 rounds to 2.
  EXPECT_EQ(FloatToHalf(2.0f - 0x1p-12f), 0x4000);
  // 65520 is the tie between 65504 and 2^16 (odd 0x7BFF): to even, i.e. infinity.
  EXPECT_EQ(FloatToHalf(65519.0f), 0x7BFF);
  EXPECT_EQ(FloatToHalf(65520.0f), 0x7C00);
  // Subnormal range, in units of 2^-24: 0.5 ties to 0, 1.5 ties to 2, 2.5 ties to 2.
  EXPECT_EQ(FloatToHalf(0x1p-25f), 0x0000);
  EXPECT_EQ(FloatToHalf(0x1.8p-25f), 0x0001);  // 0.75 units
  EXPECT_EQ(FloatToHalf(3 * 0x1p-25f), 0x0002);
  EXPECT_EQ(FloatToHalf(5 * 0x1p-25f), 0x0002);
  EXPECT_EQ(FloatToHalf(7 * 0x1p-25f), 0x0004);
  // Largest subnormal plus half a unit ties to the even 0x0400, the smallest normal.
  EXPECT_EQ(FloatToHalf(0x3FFp-24f + 0x1p-25f), 0x0400);
}

TEST(FloatToHalf, KeepsNan) {
  for (uint32_t bits : {0x7FC00000u, 0xFFC00000u, 0x7F800001u, 0x7FFFFFFFu, 0x7F802000u}) {
    SCOPED_TRACE(bits);
    const uint16_t half = FloatToHalf(std::bit_cast<float>(bits));
    EXPECT_EQ(half & 0x7C00, 0x7C00);
    EXPECT_NE(half & 0x03FF, 0) << "a NaN must not become infinity";
    EXPECT_EQ(half & 0x8000, (bits >> 16) & 0x8000);
    EXPECT_TRUE(std::isnan(HalfToFloat(half)));
  }
}

TEST(HalfToFloat, KnownBitPatterns) {
  EXPECT_EQ(HalfToFloat(0x3C00), 1.0f);
  EXPECT_EQ(HalfToFloat(0xC000), -2.0f);
  EXPECT_EQ(HalfToFloat(0x7BFF), 65504.0f);
  EXPECT_EQ(HalfToFloat(0x0400), 0x1p-14f);
  EXPECT_EQ(HalfToFloat(0x03FF), 0x3FFp-24f);
  EXPECT_EQ(HalfToFloat(0x0001), 0x1p-24f);
  EXPECT_EQ(HalfToFloat(0x8001), -0x1p-24f);
  EXPECT_EQ(HalfToFloat(0x3555), 0x1.554p-2f);  // nearest half to 1/3
  EXPECT_EQ(HalfToFloat(0x7C00), kInf);
  EXPECT_EQ(HalfToFloat(0xFC00), -kInf);
  EXPECT_TRUE(std::isnan(HalfToFloat(0x7E00)));
  EXPECT_TRUE(std::isnan(HalfToFloat(0x7C01)));
  EXPECT_EQ(HalfToFloat(0x0000), 0.0f);
  EXPECT_FALSE(std::signbit(HalfToFloat(0x0000)));
  EXPECT_EQ(HalfToFloat(0x8000), 0.0f);
  EXPECT_TRUE(std::signbit(HalfToFloat(0x8000)));
}

TEST(HalfToFloat, EveryHalfSurvivesTheRoundTrip) {
  for (uint32_t bits = 0; bits <= 0xFFFF; ++bits) {
    const uint16_t half = static_cast<uint16_t>(bits);
    const float value = HalfToFloat(half);
    if ((half & 0x7C00) == 0x7C00 && (half & 0x03FF) != 0) {
      ASSERT_TRUE(std::isnan(value)) << bits;
      continue;
    }
    ASSERT_EQ(FloatToHalf(value), half) << bits;
  }
}

#ifdef __FLT16_MAX__
// The compiler's _Float16 conversion (round to nearest even) as the reference, on random
// float bit patterns covering every exponent, and densely near the half range's edges.
TEST(FloatToHalf, AgreesWithTheCompilersFloat16OnRandomFloats) {
  std::mt19937 rng(20240611);
  std::uniform_int_distribution<uint32_t> any_bits;
  std::uniform_real_distribution<float> near_edges(-30.0f, 17.0f);
  for (int i = 0; i < 1000000; ++i) {
    float value = std::bit_cast<float>(any_bits(rng));
    if (i % 2 == 1) {  // exponents around the subnormal, normal and overflow thresholds
      value = std::ldexp(std::bit_cast<float>((any_bits(rng) & 0x807FFFFFu) | 0x3F800000u),
                         static_cast<int>(near_edges(rng)));
    }
    if (std::isnan(value)) continue;
    const uint16_t expected = std::bit_cast<uint16_t>(static_cast<_Float16>(value));
    ASSERT_EQ(FloatToHalf(value), expected) << std::hexfloat << value;
  }
}

// Every tie: the midpoint of each pair of neighbouring finite halves (exact in float), where
// random inputs almost never land.
TEST(FloatToHalf, AgreesWithTheCompilersFloat16OnEveryTie) {
  for (uint32_t bits = 0; bits < 0x7C00; ++bits) {
    for (uint32_t sign : {0x0000u, 0x8000u}) {
      const float low = HalfToFloat(static_cast<uint16_t>(sign | bits));
      const float high = HalfToFloat(static_cast<uint16_t>(sign | (bits + 1)));
      const float tie = static_cast<float>((double{low} + double{high}) / 2);
      const uint16_t expected = std::bit_cast<uint16_t>(static_cast<_Float16>(tie));
      ASSERT_EQ(FloatToHalf(tie), expected) << std::hexfloat << tie;
      ASSERT_EQ(expected & 1, 0) << "the reference itself rounds ties to even";
    }
  }
}
#endif

// ---------------------------------------------------------------------------------------------
// Encoding and decoding round trips

// A non-square ROI away from every edge of a 7x5 sensor, so that a wrong stride or offset shows.
constexpr ImageGeometry kSmallSensor{.width = 7, .height = 5};
constexpr PixelRect kRect{.x = 2, .y = 1, .width = 4, .height = 3};

// Distinct values of both signs from 0.01 to ~50, with NaN and infinities at a few pixels.
std::vector<float> MakePlane(ImageGeometry geometry) {
  std::vector<float> plane(static_cast<size_t>(geometry.pixel_count()));
  for (size_t i = 0; i < plane.size(); ++i) {
    plane[i] = 0.01f + 1.37f * static_cast<float>(i) * (i % 3 == 0 ? -1.0f : 1.0f);
  }
  return plane;
}

// The sensor pixel of ROI index i.
size_t SensorIndex(size_t i) {
  const size_t row = i / kRect.width;
  const size_t col = i % kRect.width;
  return (kRect.y + row) * kSmallSensor.width + kRect.x + col;
}

struct RoundTripCase {
  v1::Encoding encoding;
  v1::Compression compression;
};

class FloatRoundTrip : public ::testing::TestWithParam<RoundTripCase> {};

TEST_P(FloatRoundTrip, CropsAndReproducesTheValuesWithinTheEncodingsPrecision) {
  const auto [encoding, compression] = GetParam();
  std::vector<float> plane = MakePlane(kSmallSensor);
  plane[SensorIndex(1)] = kNaNf;
  plane[SensorIndex(5)] = kInf;
  plane[SensorIndex(6)] = -kInf;

  v1::Image image;
  image.set_name("range");
  ASSERT_THAT(EncodeFloatPlane(plane, kSmallSensor, kRect, encoding, compression, &image),
              IsOk());
  const int bytes_per_pixel = encoding == v1::FLOAT32 ? 4 : 2;
  EXPECT_EQ(image.width(), 4u);
  EXPECT_EQ(image.height(), 3u);
  EXPECT_EQ(image.encoding(), EncodingName(encoding));
  EXPECT_EQ(image.step(), 4u * bytes_per_pixel);
  EXPECT_EQ(image.compression(), compression);
  EXPECT_EQ(image.name(), "range");  // left to the caller
  if (compression == v1::COMPRESSION_NONE) {
    EXPECT_EQ(image.data().size(), 12u * bytes_per_pixel);
  }

  const absl::StatusOr<std::vector<float>> decoded = DecodeImage(image);
  ASSERT_THAT(decoded.status(), IsOk());
  ASSERT_EQ(decoded->size(), 12u);
  for (size_t i = 0; i < decoded->size(); ++i) {
    SCOPED_TRACE(i);
    const float sent = plane[SensorIndex(i)];
    const float got = (*decoded)[i];
    switch (encoding) {
      case v1::FLOAT32:
        if (std::isnan(sent)) {
          EXPECT_TRUE(std::isnan(got));
        } else {
          EXPECT_EQ(got, sent);
        }
        break;
      case v1::FLOAT16: {
        if (std::isnan(sent)) {
          EXPECT_TRUE(std::isnan(got));
        } else if (std::isinf(sent)) {
          EXPECT_EQ(got, sent);
        } else {
          // Round to nearest with an 11-bit significand: within half an ulp, 2^-11 relative.
          constexpr float kHalfRelativeError = 0x1p-11f;
          EXPECT_NEAR(got, sent, std::abs(sent) * kHalfRelativeError);
        }
        break;
      }
      case v1::UINT16_MM:
        if (std::isnan(sent) || !(sent > 0.0f) || sent > 65.535f) {
          EXPECT_TRUE(std::isnan(got)) << "sent " << sent;
        } else {
          constexpr float kHalfMillimetre = 0.0005f + 1e-6f;  // rounding, plus float error
          EXPECT_NEAR(got, sent, kHalfMillimetre);
        }
        break;
      default:
        FAIL() << "untested encoding";
    }
  }
}

INSTANTIATE_TEST_SUITE_P(
    EveryEncoding, FloatRoundTrip,
    ::testing::Values(RoundTripCase{v1::FLOAT32, v1::COMPRESSION_NONE},
                      RoundTripCase{v1::FLOAT32, v1::ZSTD},
                      RoundTripCase{v1::FLOAT16, v1::COMPRESSION_NONE},
                      RoundTripCase{v1::FLOAT16, v1::ZSTD},
                      RoundTripCase{v1::UINT16_MM, v1::COMPRESSION_NONE},
                      RoundTripCase{v1::UINT16_MM, v1::ZSTD}),
    [](const ::testing::TestParamInfo<RoundTripCase>& info) {
      return v1::Encoding_Name(info.param.encoding) + "_" +
             v1::Compression_Name(info.param.compression);
    });

TEST(EncodeFloatPlane, UnspecifiedEncodingIsFloat32) {
  const std::vector<float> plane = MakePlane(kSmallSensor);
  v1::Image image;
  ASSERT_THAT(EncodeFloatPlane(plane, kSmallSensor, kRect, v1::ENCODING_UNSPECIFIED,
                               v1::COMPRESSION_NONE, &image),
              IsOk());
  EXPECT_EQ(image.encoding(), "32FC1");
  EXPECT_EQ(image.step(), 16u);
}

TEST(EncodeFloatPlane, WritesLittleEndianRowMajorBytes) {
  constexpr ImageGeometry kTwoByOne{.width = 2, .height = 1};
  constexpr PixelRect kAll{.x = 0, .y = 0, .width = 2, .height = 1};
  const std::vector<float> plane = {1.0f, -2.0f};
  v1::Image image;
  ASSERT_THAT(
      EncodeFloatPlane(plane, kTwoByOne, kAll, v1::FLOAT32, v1::COMPRESSION_NONE, &image),
      IsOk());
  EXPECT_EQ(image.data(), std::string("\x00\x00\x80\x3F\x00\x00\x00\xC0", 8));
  ASSERT_THAT(
      EncodeFloatPlane(plane, kTwoByOne, kAll, v1::FLOAT16, v1::COMPRESSION_NONE, &image),
      IsOk());
  EXPECT_EQ(image.data(), std::string("\x00\x3C\x00\xC0", 4));
}

TEST(EncodeFloatPlane, MillimetresAreRoundedAndInvalidLengthsBecomeZero) {
  const std::vector<float> plane = {1.2345f, 0.001f, 65.535f, kNaNf, -1.0f,
                                    0.0f,    65.536f, kInf,  1e-5f, 2.0f};
  const ImageGeometry geometry{.width = static_cast<int>(plane.size()), .height = 1};
  const PixelRect all{.x = 0, .y = 0, .width = geometry.width, .height = 1};
  v1::Image image;
  ASSERT_THAT(
      EncodeFloatPlane(plane, geometry, all, v1::UINT16_MM, v1::COMPRESSION_NONE, &image),
      IsOk());
  ASSERT_EQ(image.data().size(), 2 * plane.size());
  std::vector<uint16_t> mm;
  for (size_t i = 0; i < plane.size(); ++i) {
    const auto* bytes = reinterpret_cast<const unsigned char*>(image.data().data()) + 2 * i;
    mm.push_back(static_cast<uint16_t>(bytes[0] | (bytes[1] << 8)));
  }
  EXPECT_THAT(mm, ::testing::ElementsAre(1235, 1, 65535, 0, 0, 0, 0, 0, 0, 2000));

  const absl::StatusOr<std::vector<float>> metres = DecodeImage(image);
  ASSERT_THAT(metres.status(), IsOk());
  EXPECT_FLOAT_EQ((*metres)[0], 1.235f);
  EXPECT_FLOAT_EQ((*metres)[1], 0.001f);
  EXPECT_FLOAT_EQ((*metres)[2], 65.535f);
  for (size_t i = 3; i <= 8; ++i) EXPECT_TRUE(std::isnan((*metres)[i])) << i;
  EXPECT_EQ((*metres)[9], 2.0f);
}

TEST(EncodeFloatPlane, UnknownEncodingOrCompressionIsRejected) {
  const std::vector<float> plane = MakePlane(kSmallSensor);
  v1::Image image;
  EXPECT_THAT(EncodeFloatPlane(plane, kSmallSensor, kRect, static_cast<v1::Encoding>(9),
                               v1::COMPRESSION_NONE, &image),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("encoding=9")));
  EXPECT_THAT(EncodeFloatPlane(plane, kSmallSensor, kRect, v1::FLOAT32,
                               static_cast<v1::Compression>(4), &image),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("compression=4")));
}

TEST(EncodeBytePlane, RoundTripsEveryByteValueThroughTheRoi) {
  constexpr ImageGeometry kSensor16x18{.width = 16, .height = 18};
  constexpr PixelRect kRoi{.x = 0, .y = 1, .width = 16, .height = 16};  // 256 pixels
  std::vector<uint8_t> plane(static_cast<size_t>(kSensor16x18.pixel_count()), 0xAA);
  for (int i = 0; i < 256; ++i) plane[16 + i] = static_cast<uint8_t>(255 - i);
  for (v1::Compression compression : {v1::COMPRESSION_NONE, v1::ZSTD}) {
    SCOPED_TRACE(v1::Compression_Name(compression));
    v1::Image image;
    ASSERT_THAT(EncodeBytePlane(plane, kSensor16x18, kRoi, compression, &image), IsOk());
    EXPECT_EQ(image.encoding(), "8UC1");
    EXPECT_EQ(image.step(), 16u);
    EXPECT_EQ(image.width(), 16u);
    EXPECT_EQ(image.height(), 16u);
    const absl::StatusOr<std::vector<float>> decoded = DecodeImage(image);
    ASSERT_THAT(decoded.status(), IsOk());
    ASSERT_EQ(decoded->size(), 256u);
    for (int i = 0; i < 256; ++i) EXPECT_EQ((*decoded)[i], static_cast<float>(255 - i)) << i;
  }
}

TEST(EncodeFloatPlane, ZstdShrinksASmoothPlane) {
  constexpr ImageGeometry kGeometry{.width = 160, .height = 120};
  const std::vector<float> plane(static_cast<size_t>(kGeometry.pixel_count()), 1.5f);
  const PixelRect all{.x = 0, .y = 0, .width = 160, .height = 120};
  v1::Image image;
  ASSERT_THAT(EncodeFloatPlane(plane, kGeometry, all, v1::FLOAT32, v1::ZSTD, &image), IsOk());
  EXPECT_LT(image.data().size(), plane.size());  // well under the 4 bytes per pixel
  EXPECT_EQ(ZSTD_getFrameContentSize(image.data().data(), image.data().size()),
            4 * plane.size());
}

// ---------------------------------------------------------------------------------------------
// Decoding corrupt images

v1::Image ValidImage(v1::Compression compression) {
  v1::Image image;
  image.set_name("depth");
  EXPECT_THAT(EncodeFloatPlane(MakePlane(kSmallSensor), kSmallSensor, kRect, v1::FLOAT32,
                               compression, &image),
              IsOk());
  return image;
}

TEST(DecodeImage, TruncatedOrOverlongDataIsDataLoss) {
  v1::Image image = ValidImage(v1::COMPRESSION_NONE);
  image.mutable_data()->pop_back();
  EXPECT_THAT(DecodeImage(image).status(),
              StatusIs(absl::StatusCode::kDataLoss,
                       AllOf(HasSubstr("image \"depth\""), HasSubstr("47 bytes"))));
  image.mutable_data()->append("xy");
  EXPECT_THAT(DecodeImage(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("49 bytes")));
  image.clear_data();
  EXPECT_THAT(DecodeImage(image).status(), StatusIs(absl::StatusCode::kDataLoss, HasSubstr("0")));
}

TEST(DecodeImage, WrongStepIsDataLoss) {
  v1::Image image = ValidImage(v1::COMPRESSION_NONE);
  image.set_step(17);
  EXPECT_THAT(DecodeImage(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("step=17")));
  // A step that makes step * height match the data size is still not width * 4.
  image.set_step(12);
  image.set_height(4);
  EXPECT_THAT(DecodeImage(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("step=12")));
}

TEST(DecodeImage, WidthAndHeightThatDoNotFitTheDataAreDataLoss) {
  v1::Image image = ValidImage(v1::COMPRESSION_NONE);
  image.set_width(6);  // 6 * 2 pixels = 48 bytes: matches the data, but not the step
  image.set_height(2);
  EXPECT_THAT(DecodeImage(image).status(), StatusIs(absl::StatusCode::kDataLoss, HasSubstr("")));
  image = ValidImage(v1::COMPRESSION_NONE);
  image.set_width(0);
  image.set_step(0);
  EXPECT_THAT(DecodeImage(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("width=0")));
  // Products that overflow 32 bits (and 64 bits once multiplied by the pixel size).
  image = ValidImage(v1::COMPRESSION_NONE);
  image.set_width(0xFFFFFFFFu);
  image.set_height(0xFFFFFFFFu);
  image.set_step(0xFFFFFFFCu);  // 4 * width, wrapped
  EXPECT_THAT(DecodeImage(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("pixels")));
  image.set_width(0x40000000u);  // 4 * width wraps to 0 in uint32
  image.set_height(1);
  image.set_step(0);
  EXPECT_THAT(DecodeImage(image).status(), StatusIs(absl::StatusCode::kDataLoss, HasSubstr("")));
}

TEST(DecodeImage, UnknownEncodingOrCompressionIsDataLoss) {
  v1::Image image = ValidImage(v1::COMPRESSION_NONE);
  for (const char* encoding : {"", "32FC3", "mono8", "32fc1", "16SC1"}) {
    image.set_encoding(encoding);
    EXPECT_THAT(DecodeImage(image).status(),
                StatusIs(absl::StatusCode::kDataLoss,
                         HasSubstr(std::string("encoding=\"") + encoding + "\"")));
  }
  image = ValidImage(v1::COMPRESSION_NONE);
  image.set_compression(static_cast<v1::Compression>(3));
  EXPECT_THAT(DecodeImage(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("compression=3")));
}

TEST(DecodeImage, GarbageOrTruncatedZstdIsDataLoss) {
  v1::Image image = ValidImage(v1::ZSTD);
  const std::string frame = image.data();

  image.set_data(std::string(48, 'z'));  // not a zstd frame at all
  EXPECT_THAT(DecodeImage(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("zstd")));
  image.set_data("");
  EXPECT_THAT(DecodeImage(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("zstd")));

  // Data cut inside the frame: the header and declared size are fine, the blocks are not.
  image.set_data(frame.substr(0, frame.size() - 3));
  EXPECT_THAT(DecodeImage(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("zstd")));

  // Two frames, or trailing bytes after the frame.
  image.set_data(frame + frame);
  EXPECT_THAT(DecodeImage(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("exactly one zstd frame")));

  // The header of a valid frame followed by garbage blocks.
  std::string corrupt = frame;
  for (size_t i = 6; i < corrupt.size(); ++i) corrupt[i] = static_cast<char>(0xFF - i);
  image.set_data(corrupt);
  EXPECT_THAT(DecodeImage(image).status(), StatusIs(absl::StatusCode::kDataLoss, HasSubstr("")));
}

// Compresses `total` zero bytes into one frame that declares (or, with declare_size = false,
// does not declare) its content size, from a 1 MiB buffer so the test itself stays small.
std::string CompressZeros(size_t total, bool declare_size) {
  ZSTD_CCtx* context = ZSTD_createCCtx();
  if (declare_size) ZSTD_CCtx_setPledgedSrcSize(context, total);
  const std::string zeros(std::min<size_t>(total, size_t{1} << 20), '\0');
  std::string out;
  std::string buffer(ZSTD_CStreamOutSize(), '\0');
  size_t left = total;
  bool done = false;
  while (!done) {
    const size_t chunk = std::min(left, zeros.size());
    left -= chunk;
    const ZSTD_EndDirective mode = left == 0 && declare_size ? ZSTD_e_end : ZSTD_e_continue;
    ZSTD_inBuffer input{zeros.data(), chunk, 0};
    size_t remaining = 0;
    do {
      ZSTD_outBuffer output{buffer.data(), buffer.size(), 0};
      remaining = ZSTD_compressStream2(context, &output, &input, mode);
      EXPECT_FALSE(ZSTD_isError(remaining)) << ZSTD_getErrorName(remaining);
      if (ZSTD_isError(remaining)) break;
      out.append(buffer.data(), output.pos);
    } while (mode == ZSTD_e_end ? remaining != 0 : input.pos < input.size);
    if (left == 0 && !declare_size) {
      // Without a pledged size, ending in a separate call leaves the size undeclared.
      ZSTD_inBuffer empty{nullptr, 0, 0};
      do {
        ZSTD_outBuffer output{buffer.data(), buffer.size(), 0};
        remaining = ZSTD_compressStream2(context, &output, &empty, ZSTD_e_end);
        EXPECT_FALSE(ZSTD_isError(remaining));
        if (ZSTD_isError(remaining)) break;
        out.append(buffer.data(), output.pos);
      } while (remaining != 0);
    }
    done = left == 0;
  }
  ZSTD_freeCCtx(context);
  return out;
}

TEST(DecodeImage, ZstdBombIsRefusedBeforeDecompressing) {
  constexpr size_t kBomb = size_t{300} << 20;  // more than the 256 MiB limit
  const std::string bomb = CompressZeros(kBomb, /*declare_size=*/true);
  ASSERT_EQ(ZSTD_getFrameContentSize(bomb.data(), bomb.size()), kBomb);
  ASSERT_LT(bomb.size(), size_t{1} << 20);

  // A small image whose frame claims 300 MiB.
  v1::Image image = ValidImage(v1::ZSTD);
  image.set_data(bomb);
  EXPECT_THAT(DecodeImage(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("314572800")));

  // An image whose geometry agrees with the bomb: refused by the size limit.
  image.set_encoding("8UC1");
  image.set_width(static_cast<uint32_t>(kBomb / 1024));
  image.set_height(1024);
  image.set_step(image.width());
  EXPECT_THAT(DecodeImage(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("at most")));
}

TEST(DecodeImage, ZstdFrameWithoutDeclaredSizeIsDataLoss) {
  v1::Image image = ValidImage(v1::ZSTD);
  const std::string frame = CompressZeros(48, /*declare_size=*/false);
  ASSERT_EQ(ZSTD_getFrameContentSize(frame.data(), frame.size()), ZSTD_CONTENTSIZE_UNKNOWN);
  image.set_data(frame);
  EXPECT_THAT(DecodeImage(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("content size")));
}

TEST(DecodeImage, RandomCorruptionIsEitherDecodedOrDataLoss) {
  std::mt19937 rng(7);
  for (v1::Compression compression : {v1::COMPRESSION_NONE, v1::ZSTD}) {
    const v1::Image valid = ValidImage(compression);
    for (int trial = 0; trial < 2000; ++trial) {
      v1::Image image = valid;
      std::string& data = *image.mutable_data();
      switch (trial % 4) {
        case 0:  // flip a few bytes
          for (int k = 0; k < 3; ++k) data[rng() % data.size()] ^= static_cast<char>(1 + rng() % 255);
          break;
        case 1:  // truncate
          data.resize(rng() % data.size());
          break;
        case 2:  // change the geometry
          image.set_width(rng() % 16);
          image.set_height(rng() % 16);
          image.set_step(rng() % 80);
          break;
        case 3:  // change the encoding
          image.set_encoding(std::vector<std::string>{"16FC1", "16UC1", "8UC1", "32FC1"}[rng() % 4]);
          break;
      }
      const absl::StatusOr<std::vector<float>> decoded = DecodeImage(image);
      if (decoded.ok()) {
        EXPECT_EQ(decoded->size(), uint64_t{image.width()} * image.height());
      } else {
        EXPECT_EQ(decoded.status().code(), absl::StatusCode::kDataLoss) << decoded.status();
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// EncodeMomentDepth / DecodeMomentDepth

// A 163x120 moment depth map of a slanted plane, built by the library.
MomentDepthMap SlantedPlaneMap(MomentMapFormat format) {
  std::vector<float> depth(static_cast<size_t>(kSensor.pixel_count()));
  for (int64_t p = 0; p < kSensor.pixel_count(); ++p) {
    depth[p] = 1.0f + 0.02f * static_cast<float>(p % kSensor.width);
  }
  depth[5] = kNaNf;  // one invalid pixel
  MomentDepthMap map;
  absl::StatusOr<MomentDepthMapBuilder> builder = MomentDepthMapBuilder::Create(
      kSensor, {.normalisation = {.near_m = 0.5, .far_m = 5.0}, .sigma_px = 1.0, .format = format});
  EXPECT_THAT(builder.status(), IsOk());
  if (builder.ok()) {
    EXPECT_THAT(builder->Build(depth, &map), IsOk());
  }
  return map;
}

TEST(EncodeMomentDepth, RoundTripsBothFormatsThroughTheRoiWithAndWithoutZstd) {
  const PixelRect rect{.x = 10, .y = 7, .width = 50, .height = 31};
  for (MomentMapFormat format : {MomentMapFormat::kOptimized64, MomentMapFormat::kFloat128}) {
    const MomentDepthMap map = SlantedPlaneMap(format);
    for (v1::Compression compression : {v1::COMPRESSION_NONE, v1::ZSTD}) {
      v1::Image image;
      ASSERT_THAT(EncodeMomentDepth(map, true, rect, compression, &image), IsOk());
      const bool optimized = format == MomentMapFormat::kOptimized64;
      EXPECT_EQ(image.encoding(), optimized ? "16UC4" : "32FC4");
      EXPECT_EQ(image.step(), 50u * (optimized ? 8u : 16u));
      EXPECT_EQ(image.moment_depth().bits(), optimized ? 64u : 128u);
      EXPECT_TRUE(image.moment_depth().from_returns());
      EXPECT_DOUBLE_EQ(image.moment_depth().near_m(), 0.5);
      EXPECT_DOUBLE_EQ(image.moment_depth().far_m(), 5.0);
      EXPECT_EQ(ImageChannels(image), 4);
      absl::StatusOr<MomentDepthMap> decoded = DecodeMomentDepth(image);
      ASSERT_THAT(decoded.status(), IsOk());
      EXPECT_EQ(decoded->geometry, (ImageGeometry{50, 31}));
      for (int y = 0; y < rect.height; ++y) {
        for (int x = 0; x < rect.width; ++x) {
          EXPECT_EQ(decoded->Texel(x, y), map.Texel(rect.x + x, rect.y + y)) << x << "," << y;
          EXPECT_EQ(decoded->Occlusion(x, y, 1.5), map.Occlusion(rect.x + x, rect.y + y, 1.5));
        }
      }
    }
  }
}

TEST(DecodeMomentDepth, MissingInfoMismatchedBitsBadRangeAndNanMomentsAreDataLoss) {
  const PixelRect whole{.x = 0, .y = 0, .width = kSensor.width, .height = kSensor.height};
  v1::Image valid;
  ASSERT_THAT(EncodeMomentDepth(SlantedPlaneMap(MomentMapFormat::kFloat128), false, whole,
                                v1::COMPRESSION_NONE, &valid),
              IsOk());
  v1::Image image = valid;
  image.clear_moment_depth();
  EXPECT_THAT(DecodeMomentDepth(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("no moment_depth info")));
  image = valid;
  image.mutable_moment_depth()->set_bits(64);
  EXPECT_THAT(DecodeMomentDepth(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("bits=64 with encoding=\"32FC4\"")));
  image = valid;
  image.mutable_moment_depth()->set_far_m(0.1);
  EXPECT_THAT(DecodeMomentDepth(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("moment_depth: ")));
  image = valid;
  const uint32_t nan_bits = std::bit_cast<uint32_t>(kNaNf);
  std::memcpy(image.mutable_data()->data() + 4 * 4 * 7 + 4, &nan_bits, 4);  // b2 of pixel 7
  EXPECT_THAT(DecodeMomentDepth(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("moment 2 of pixel 7 is nan")));
  image = valid;
  image.mutable_data()->resize(image.data().size() - 3);
  EXPECT_THAT(DecodeMomentDepth(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("data holds")));
  image = valid;
  image.set_step(kSensor.width * 4);  // one float per pixel: not 32FC4
  EXPECT_THAT(DecodeMomentDepth(image).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("step=")));
}

}  // namespace
}  // namespace transient::wire
