// The V4L2 buffer unpacker on byte arrays written from the formats' documentation (the kernel's
// pixfmt pages, as quoted in ../shared/research/v4l2.md §2.2): low-aligned 16-bit words for
// Y12/BG12/Y16, MIPI RAW12 pairs for Y12P/pBCC, strides with padding, signed samples, and every
// bad input.
#include "v4l2/frame_unpacker.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <vector>

#include "tests/support/status_matchers.h"

namespace transient::v4l2 {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

FrameLayout Layout(int width, int height, size_t bytes_per_line) {
  return {.geometry = {width, height}, .bytes_per_line = bytes_per_line};
}

std::vector<float> UnpackOk(const std::vector<uint8_t>& data, const FrameLayout& layout,
                            const SampleFormat& format) {
  std::vector<float> pixels(static_cast<size_t>(layout.geometry.pixel_count()), -1.0f);
  EXPECT_THAT(Unpack(data, layout, format, pixels), IsOk());
  return pixels;
}

TEST(Fourcc, NamesAreTheFourCharactersWithoutPadding) {
  EXPECT_EQ(kFourccY12P, 0x50323159u);  // v4l2_fourcc('Y','1','2','P')
  EXPECT_EQ(FourccName(kFourccY12P), "Y12P");
  EXPECT_EQ(FourccName(kFourccY12), "Y12");
  EXPECT_EQ(FourccName(kFourccSBGGR12P), "pBCC");
  EXPECT_EQ(FourccName(Fourcc('A', 'B', '\x01', 'C')), "AB\\x01C");
}

TEST(FrameUnpacker, Y12IsLowAlignedLittleEndianWords) {
  // 0x0123, 0x0fff, 0x0000, 0x0800 as LE words.
  const std::vector<uint8_t> data = {0x23, 0x01, 0xff, 0x0f, 0x00, 0x00, 0x00, 0x08};
  EXPECT_THAT(UnpackOk(data, Layout(4, 1, 8), {.fourcc = kFourccY12}),
              ElementsAre(0x123, 0xfff, 0, 0x800));
  EXPECT_THAT(UnpackOk(data, Layout(2, 2, 4), {.fourcc = kFourccSBGGR12}),
              ElementsAre(0x123, 0xfff, 0, 0x800));
}

TEST(FrameUnpacker, Y12PPacksTwoSamplesInThreeBytes) {
  // P0 = 0xabc, P1 = 0x123: byte 0 = P0[11:4] = 0xab, byte 1 = P1[11:4] = 0x12,
  // byte 2 = P1[3:0] << 4 | P0[3:0] = 0x3c. Then P2 = 0x000, P3 = 0xfff.
  const std::vector<uint8_t> data = {0xab, 0x12, 0x3c, 0x00, 0xff, 0xf0};
  EXPECT_THAT(UnpackOk(data, Layout(4, 1, 6), {.fourcc = kFourccY12P}),
              ElementsAre(0xabc, 0x123, 0x000, 0xfff));
  EXPECT_THAT(UnpackOk(data, Layout(4, 1, 6), {.fourcc = kFourccSBGGR12P}),
              ElementsAre(0xabc, 0x123, 0x000, 0xfff));
}

TEST(FrameUnpacker, SignedTwelveBitSamplesAreTwosComplement) {
  // The MLX7502x's A-B output: 0x7ff = 2047, 0x800 = -2048, 0xfff = -1, 0x001 = 1.
  const std::vector<uint8_t> y12 = {0xff, 0x07, 0x00, 0x08, 0xff, 0x0f, 0x01, 0x00};
  EXPECT_THAT(UnpackOk(y12, Layout(4, 1, 8), {.fourcc = kFourccY12, .is_signed = true}),
              ElementsAre(2047, -2048, -1, 1));
  // The same four samples packed: pairs (0x7ff, 0x800) and (0xfff, 0x001).
  const std::vector<uint8_t> y12p = {0x7f, 0x80, 0x0f, 0xff, 0x00, 0x1f};
  EXPECT_THAT(UnpackOk(y12p, Layout(4, 1, 6), {.fourcc = kFourccY12P, .is_signed = true}),
              ElementsAre(2047, -2048, -1, 1));
}

TEST(FrameUnpacker, ShiftDropsLowBitsOfHighAlignedSamples) {
  // 12-bit samples high in a Y16 word (value << 4), as some receivers deliver them.
  const std::vector<uint8_t> data = {0x30, 0x12, 0xf0, 0xff};  // 0x1230, 0xfff0
  EXPECT_THAT(UnpackOk(data, Layout(2, 1, 4), {.fourcc = kFourccY16, .bits = 12, .shift = 4}),
              ElementsAre(0x123, 0xfff));
  EXPECT_THAT(UnpackOk(data, Layout(2, 1, 4),
                       {.fourcc = kFourccY16, .bits = 12, .shift = 4, .is_signed = true}),
              ElementsAre(0x123, -1));
  EXPECT_THAT(UnpackOk(data, Layout(2, 1, 4), {.fourcc = kFourccY16, .bits = 16}),
              ElementsAre(0x1230, 0xfff0));
  EXPECT_THAT(UnpackOk(data, Layout(2, 1, 4), {.fourcc = kFourccY16, .bits = 16, .is_signed = true}),
              ElementsAre(0x1230, -16));
}

TEST(FrameUnpacker, StrideSkipsThePaddingAtTheEndOfEachRow) {
  // 2x3 Y12P with 8 bytes per line: 3 bytes of samples, 5 of padding (0xee), per row; the last
  // row may end without its padding.
  const std::vector<uint8_t> data = {
      0x10, 0x20, 0x21, 0xee, 0xee, 0xee, 0xee, 0xee,  // 0x101, 0x202
      0x30, 0x40, 0x43, 0xee, 0xee, 0xee, 0xee, 0xee,  // 0x303, 0x404
      0x50, 0x60, 0x65,                                // 0x505, 0x606
  };
  EXPECT_THAT(UnpackOk(data, Layout(2, 3, 8), {.fourcc = kFourccY12P}),
              ElementsAre(0x101, 0x202, 0x303, 0x404, 0x505, 0x606));
}

TEST(FrameUnpacker, PackedAndWordContainersAgreeOnRandomSamples) {
  // The same random 12-bit samples written in each container as the kernel documents it.
  std::mt19937 rng(5);
  const int width = 16, height = 5;
  std::vector<uint16_t> samples(width * height);
  for (uint16_t& s : samples) s = static_cast<uint16_t>(rng() & 0xfff);
  std::vector<uint8_t> words, packed;
  for (uint16_t s : samples) {
    words.push_back(static_cast<uint8_t>(s & 0xff));
    words.push_back(static_cast<uint8_t>(s >> 8));
  }
  for (size_t i = 0; i < samples.size(); i += 2) {
    packed.push_back(static_cast<uint8_t>(samples[i] >> 4));
    packed.push_back(static_cast<uint8_t>(samples[i + 1] >> 4));
    packed.push_back(static_cast<uint8_t>((samples[i + 1] & 0xf) << 4 | (samples[i] & 0xf)));
  }
  const std::vector<float> expected(samples.begin(), samples.end());
  for (bool is_signed : {false, true}) {
    const std::vector<float> from_words =
        UnpackOk(words, Layout(width, height, 2 * width), {.fourcc = kFourccY12, .is_signed = is_signed});
    const std::vector<float> from_packed = UnpackOk(
        packed, Layout(width, height, 3 * width / 2), {.fourcc = kFourccY12P, .is_signed = is_signed});
    EXPECT_EQ(from_words, from_packed);
    if (!is_signed) {
      EXPECT_EQ(from_words, expected);
    }
  }
}

TEST(FrameUnpacker, ShortBufferIsDataLossNamingTheSizes) {
  const std::vector<uint8_t> data(11, 0);  // 2x2 Y12 with 8 bytes per line needs 8 + 4 = 12
  std::vector<float> pixels(4);
  EXPECT_THAT(Unpack(data, Layout(2, 2, 8), {.fourcc = kFourccY12}, pixels),
              StatusIs(absl::StatusCode::kDataLoss,
                       AllOf(HasSubstr("short buffer"), HasSubstr("11 bytes"), HasSubstr("needs 12"))));
  EXPECT_THAT(Unpack({}, Layout(2, 1, 6), {.fourcc = kFourccY12P}, std::span(pixels).first(2)),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("0 bytes")));
}

TEST(FrameUnpacker, BitsAboveTheSampleAreDataLossNamingThePixel) {
  // 0x1230 in a Y12 word: bits above bit 11 set, e.g. a receiver that MSB-aligns.
  const std::vector<uint8_t> data = {0x00, 0x00, 0x30, 0x12};
  std::vector<float> pixels(2);
  EXPECT_THAT(Unpack(data, Layout(2, 1, 4), {.fourcc = kFourccY12}, pixels),
              StatusIs(absl::StatusCode::kDataLoss,
                       AllOf(HasSubstr("0x1230"), HasSubstr("pixel (1, 0)"), HasSubstr("above bit 11"),
                             HasSubstr("set shift"))));
  // Ten-bit samples in a Y12 container must keep bits 10 and 11 clear.
  const std::vector<uint8_t> ten = {0xff, 0x03, 0x00, 0x04};
  EXPECT_THAT(Unpack(ten, Layout(2, 1, 4), {.fourcc = kFourccY12, .bits = 10}, pixels),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("pixel (1, 0)")));
}

TEST(FrameUnpacker, BadFormatsAndLayoutsAreRefusedNamingTheField) {
  std::vector<float> pixels(4);
  const std::vector<uint8_t> data(64, 0);
  EXPECT_THAT(Unpack(data, Layout(2, 2, 4), {.fourcc = Fourcc('Y', 'U', 'Y', 'V')}, pixels),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("'YUYV' is not one we read"), HasSubstr("Y12P"))));
  EXPECT_THAT((SampleFormat{.fourcc = kFourccY12, .bits = 13}).Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("bits=13 is outside 1..12")));
  EXPECT_THAT((SampleFormat{.fourcc = kFourccY12P, .bits = 0}).Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("bits=0")));
  EXPECT_THAT((SampleFormat{.fourcc = kFourccY16, .bits = 12, .shift = 5}).Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("shift=5 with bits=12")));
  EXPECT_THAT((SampleFormat{.fourcc = kFourccY16, .bits = 12, .shift = -1}).Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("shift=-1")));
  EXPECT_THAT((SampleFormat{.fourcc = kFourccY16, .bits = 16}).Validate(), IsOk());
  EXPECT_THAT(Unpack(data, Layout(3, 1, 6), {.fourcc = kFourccY12P}, std::span(pixels).first(3)),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("width 3 is odd")));
  EXPECT_THAT(Unpack(data, Layout(2, 2, 5), {.fourcc = kFourccY12P}, pixels), IsOk());
  EXPECT_THAT(Unpack(data, Layout(2, 2, 2), {.fourcc = kFourccY12P}, pixels),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("bytes per line 2"), HasSubstr("3 bytes of a row"))));
  EXPECT_THAT(Unpack(data, Layout(0, 2, 4), {.fourcc = kFourccY12}, {}),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("0x2 is not positive")));
  EXPECT_THAT(Unpack(data, Layout(2, 2, 4), {.fourcc = kFourccY12}, std::span(pixels).first(3)),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("output holds 3 pixels")));
}

}  // namespace
}  // namespace transient::v4l2
