// PNG and float TIFF writers read back with libpng and libtiff, and the colour map's invariants.
#include "tools/transient/common/image_writers.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <png.h>
#include <tiffio.h>

#include <bit>
#include <cmath>
#include <filesystem>
#include <limits>
#include <vector>

#include "tests/tools/image_readers.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"

namespace transient::tools {
namespace {

using ::testing::ElementsAreArray;
using ::testing::HasSubstr;
using testing::ReadPng;
using testing::ReadTiff;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;

TEST(WritePng16, ReadsBackExactlyWithBigEndianSamples) {
  ScratchDirectory dir;
  const ImageGeometry geometry{.width = 4, .height = 3};
  const std::vector<uint16_t> pixels = {0,      1,      255,    256,   0x1234, 0xff00,
                                        0x00ff, 0xfffe, 0xffff, 32767, 32768,  4242};
  ASSERT_THAT(WritePng16(dir.File("depth.png"), geometry, pixels), ::transient::testing::IsOk());

  const testing::RawPng png = ReadPng(dir.File("depth.png"));
  EXPECT_EQ(png.width, 4u);
  EXPECT_EQ(png.height, 3u);
  EXPECT_EQ(png.bit_depth, 16);
  EXPECT_EQ(png.colour_type, PNG_COLOR_TYPE_GRAY);
  ASSERT_EQ(png.bytes.size(), pixels.size() * 2);
  std::vector<uint16_t> read(pixels.size());
  for (size_t i = 0; i < read.size(); ++i) {
    read[i] = static_cast<uint16_t>(png.bytes[2 * i] << 8 | png.bytes[2 * i + 1]);
  }
  EXPECT_THAT(read, ElementsAreArray(pixels));
}

TEST(WritePng8, GrayAndRgbReadBackExactly) {
  ScratchDirectory dir;
  const ImageGeometry geometry{.width = 3, .height = 2};
  const std::vector<uint8_t> gray = {0, 1, 2, 127, 128, 255};
  ASSERT_THAT(WritePng8(dir.File("flags.png"), geometry, gray), ::transient::testing::IsOk());
  const testing::RawPng gray_png = ReadPng(dir.File("flags.png"));
  EXPECT_EQ(gray_png.bit_depth, 8);
  EXPECT_EQ(gray_png.colour_type, PNG_COLOR_TYPE_GRAY);
  EXPECT_THAT(gray_png.bytes, ElementsAreArray(gray));

  std::vector<uint8_t> rgb(geometry.pixel_count() * 3);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = static_cast<uint8_t>(i * 13);
  ASSERT_THAT(WritePngRgb8(dir.File("slice.png"), geometry, rgb), ::transient::testing::IsOk());
  const testing::RawPng rgb_png = ReadPng(dir.File("slice.png"));
  EXPECT_EQ(rgb_png.width, 3u);
  EXPECT_EQ(rgb_png.height, 2u);
  EXPECT_EQ(rgb_png.bit_depth, 8);
  EXPECT_EQ(rgb_png.colour_type, PNG_COLOR_TYPE_RGB);
  EXPECT_THAT(rgb_png.bytes, ElementsAreArray(rgb));
}

TEST(WriteTiffFloat, ReadsBackBitForBitIncludingNanAndInfinity) {
  ScratchDirectory dir;
  const ImageGeometry geometry{.width = 5, .height = 2};
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<float> pixels = {
      0.0f, -0.0f, 1.5f, nan, std::numeric_limits<float>::infinity(),
      -std::numeric_limits<float>::infinity(), std::numeric_limits<float>::denorm_min(),
      3.14159265f, 1e30f, -2.75f};
  ASSERT_THAT(WriteTiffFloat(dir.File("range.tiff"), geometry, pixels), ::transient::testing::IsOk());

  const testing::RawTiff tiff = ReadTiff(dir.File("range.tiff"));
  EXPECT_EQ(tiff.width, 5u);
  EXPECT_EQ(tiff.height, 2u);
  EXPECT_EQ(tiff.bits_per_sample, 32);
  EXPECT_EQ(tiff.samples_per_pixel, 1);
  EXPECT_EQ(tiff.sample_format, SAMPLEFORMAT_IEEEFP);
  ASSERT_EQ(tiff.values.size(), pixels.size());
  for (size_t i = 0; i < pixels.size(); ++i) {
    EXPECT_EQ(std::bit_cast<uint32_t>(tiff.values[i]), std::bit_cast<uint32_t>(pixels[i]))
        << "pixel " << i;
  }
  EXPECT_TRUE(std::isnan(tiff.values[3]));
}

TEST(ImageWriters, MissingDirectoryIsNotFoundNamingThePath) {
  ScratchDirectory dir;
  const std::string path = dir.File("no/such/dir/out.png");
  const std::vector<uint16_t> pixels(4, 1);
  EXPECT_THAT(WritePng16(path, {2, 2}, pixels),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr(path)));
  const std::string tiff_path = dir.File("no/such/dir/out.tiff");
  EXPECT_THAT(WriteTiffFloat(tiff_path, {2, 2}, std::vector<float>(4, 1.0f)),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr(tiff_path)));
}

TEST(ImageWriters, FullDiskIsResourceExhaustedNamingThePath) {
  if (!std::filesystem::exists("/dev/full")) GTEST_SKIP() << "no /dev/full here";
  // Large enough that the data cannot sit in stdio's buffer until after the check.
  const ImageGeometry geometry{.width = 256, .height = 256};
  std::vector<uint16_t> pixels(geometry.pixel_count());
  for (size_t i = 0; i < pixels.size(); ++i) pixels[i] = static_cast<uint16_t>(i * 7919);
  EXPECT_THAT(WritePng16("/dev/full", geometry, pixels),
              StatusIs(absl::StatusCode::kResourceExhausted, HasSubstr("/dev/full")));
  EXPECT_THAT(WriteTiffFloat("/dev/full", geometry, std::vector<float>(pixels.size(), 1.0f)),
              StatusIs(absl::StatusCode::kResourceExhausted, HasSubstr("/dev/full")));
  EXPECT_TRUE(std::filesystem::exists("/dev/full"));  // a device is never removed
}

TEST(ImageWriters, PlaneOfTheWrongSizeOrEmptyGeometryIsRefused) {
  ScratchDirectory dir;
  EXPECT_THAT(WritePng16(dir.File("a.png"), {3, 2}, std::vector<uint16_t>(5)),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("expected 6")));
  EXPECT_THAT(WritePngRgb8(dir.File("b.png"), {3, 2}, std::vector<uint8_t>(6)),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("expected 18")));
  EXPECT_THAT(WriteTiffFloat(dir.File("c.tiff"), {0, 2}, std::vector<float>()),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("width > 0")));
  EXPECT_TRUE(dir.Entries().empty());
}

TEST(MetresToMillimetres, RoundsAndMarksInvalidAsZero) {
  EXPECT_EQ(MetresToMillimetres(1.5f), 1500);
  EXPECT_EQ(MetresToMillimetres(0.0014f), 1);
  EXPECT_EQ(MetresToMillimetres(65.535f), 65535);
  EXPECT_EQ(MetresToMillimetres(65.536f), 0);  // does not fit 16 bits
  EXPECT_EQ(MetresToMillimetres(0.0f), 0);
  EXPECT_EQ(MetresToMillimetres(-1.0f), 0);
  EXPECT_EQ(MetresToMillimetres(std::numeric_limits<float>::quiet_NaN()), 0);
  EXPECT_EQ(MetresToMillimetres(std::numeric_limits<float>::infinity()), 0);
}

// Rec. 709 luma of sRGB values: enough to order colours by brightness.
double Luma(Rgb8 colour) { return 0.2126 * colour.r + 0.7152 * colour.g + 0.0722 * colour.b; }

TEST(ColourMap, EndpointsAreNearBlackAndPaleYellow) {
  EXPECT_EQ(ColourMap(0.0f, 1.0f), (Rgb8{0, 0, 4}));
  EXPECT_EQ(ColourMap(1.0f, 1.0f), (Rgb8{252, 255, 164}));
  EXPECT_LT(Luma(ColourMap(0.0f, 1.0f)), 5.0);
  EXPECT_GT(Luma(ColourMap(1.0f, 1.0f)), 240.0);
}

TEST(ColourMap, ClampsOutOfRangeAndInfiniteValues) {
  EXPECT_EQ(ColourMap(-3.0f, 1.0f), ColourMap(0.0f, 1.0f));
  EXPECT_EQ(ColourMap(7.0f, 1.0f), ColourMap(1.0f, 1.0f));
  EXPECT_EQ(ColourMap(-std::numeric_limits<float>::infinity(), 2.0f), ColourMap(0.0f, 1.0f));
  EXPECT_EQ(ColourMap(std::numeric_limits<float>::infinity(), 2.0f), ColourMap(1.0f, 1.0f));
}

TEST(ColourMap, DividesByTheScale) {
  EXPECT_EQ(ColourMap(2.0f, 4.0f), ColourMap(0.5f, 1.0f));
  EXPECT_EQ(ColourMap(0.003f, 0.01f), ColourMap(0.3f, 1.0f));
}

TEST(ColourMap, NanIsTheNoValueGreyWhichNoValueMapsTo) {
  EXPECT_EQ(ColourMap(std::numeric_limits<float>::quiet_NaN(), 1.0f), kNoValueGrey);
  for (int i = 0; i <= 1024; ++i) {
    EXPECT_NE(ColourMap(i / 1024.0f, 1.0f), kNoValueGrey) << "t = " << i / 1024.0;
  }
}

TEST(ColourMap, LuminanceRisesStrictly) {
  // 64 steps: each step crosses at least 1/8 of a control interval, far more than rounding.
  constexpr int kSteps = 64;
  double previous = -1.0;
  for (int i = 0; i <= kSteps; ++i) {
    const double luma = Luma(ColourMap(static_cast<float>(i) / kSteps, 1.0f));
    EXPECT_GT(luma, previous) << "t = " << static_cast<double>(i) / kSteps;
    previous = luma;
  }
}

TEST(ColourMapPlane, WritesThreeBytesPerValueInOrder) {
  const std::vector<float> values = {0.0f, std::numeric_limits<float>::quiet_NaN(), 2.0f};
  const std::vector<uint8_t> rgb = ColourMapPlane(values, 2.0f);
  EXPECT_THAT(rgb, ElementsAreArray({0, 0, 4, 128, 128, 128, 252, 255, 164}));
}

}  // namespace
}  // namespace transient::tools
