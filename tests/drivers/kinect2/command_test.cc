// The Kinect v2 command codec: the bytes of a command, the response-complete block, and the
// responses read at open (research/libusb.md §1.2), with their bad inputs.
#include "kinect2/command.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "tests/support/status_matchers.h"

namespace transient::kinect2 {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::IsOkAndHolds;
using ::transient::testing::StatusIs;

void Put(std::vector<uint8_t>* out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<uint8_t>(v >> (8 * i)));
}
void PutFloat(std::vector<uint8_t>* out, float f) {
  uint32_t v;
  std::memcpy(&v, &f, 4);
  Put(out, v);
}

TEST(Command, IsLittleEndianMagicSequenceLengthIdZeroAndParams) {
  const uint32_t params[] = {1, 0x00640064};
  EXPECT_THAT(EncodeCommand(7, kSetMode, 0x200, params),
              ElementsAre(0x09, 0x20, 0x02, 0x06, 7, 0, 0, 0, 0x00, 0x02, 0, 0, 0x4B, 0, 0, 0, 0,
                          0, 0, 0, 1, 0, 0, 0, 0x64, 0, 0x64, 0));
  EXPECT_EQ(CommandName(kReadData), "read data (0x22)");
  EXPECT_EQ(CommandName(0x3E), "command 0x3E");
}

TEST(Command, CompleteBlockMustHaveTheMagicAndTheSequence) {
  std::vector<uint8_t> block;
  Put(&block, 0x0A6FE000);
  Put(&block, 6);
  Put(&block, 0);
  Put(&block, 0);
  EXPECT_THAT(CheckComplete(block, 6), IsOk());
  EXPECT_THAT(CheckComplete(block, 7), StatusIs(absl::StatusCode::kDataLoss,
                                                HasSubstr("sequence 6, expected 7")));
  block[0] = 1;
  EXPECT_THAT(CheckComplete(block, 6),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("magic 0x0A6FE001")));
  block.resize(12);
  EXPECT_THAT(CheckComplete(block, 6),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("of 12 bytes, expected 16")));
}

TEST(Responses, FirmwareSerialIntrinsicsAndStatus) {
  std::vector<uint8_t> firmware(7 * 16, 0);
  const uint32_t entry[4] = {4u << 16 | 0, 3912, 0, 0};
  std::memcpy(firmware.data() + 3 * 16, entry, 16);
  EXPECT_THAT(ParseFirmwareVersion(firmware), IsOkAndHolds(std::string("4.0.3912.0")));
  firmware.resize(63);
  EXPECT_THAT(ParseFirmwareVersion(firmware).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("at least 64")));

  const std::vector<uint8_t> serial = {'0', 0, '1', 0, '2', 0, 0, 0, 'x', 0};
  EXPECT_THAT(ParseSerial(serial), IsOkAndHolds(std::string("012")));
  EXPECT_THAT(ParseSerial(std::vector<uint8_t>(0x80, 0)).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("empty serial")));

  std::vector<uint8_t> intrinsics;
  for (float f : {365.5f, 366.0f, 0.0f, 257.0f, 208.5f, 0.09f, -0.27f, 0.0f, 0.0f, 0.1f}) {
    PutFloat(&intrinsics, f);
  }
  intrinsics.resize(92, 0);
  absl::StatusOr<DepthIntrinsics> d = ParseDepthIntrinsics(intrinsics);
  ASSERT_THAT(d.status(), IsOk());
  EXPECT_FLOAT_EQ(d->fx, 365.5f);
  EXPECT_FLOAT_EQ(d->fy, 366.0f);
  EXPECT_FLOAT_EQ(d->cx, 257.0f);
  EXPECT_FLOAT_EQ(d->cy, 208.5f);
  EXPECT_FLOAT_EQ(d->distortion[0], 0.09f);   // k1
  EXPECT_FLOAT_EQ(d->distortion[1], -0.27f);  // k2
  EXPECT_FLOAT_EQ(d->distortion[4], 0.1f);    // k3
  intrinsics.resize(91);
  EXPECT_THAT(ParseDepthIntrinsics(intrinsics).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("91 bytes; expected 92")));
  EXPECT_THAT(ParseDepthIntrinsics(std::vector<uint8_t>(92, 0)).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("focal length 0")));

  std::vector<uint8_t> status;
  Put(&status, 9731);
  EXPECT_THAT(ParseStatus(status), IsOkAndHolds(9731u));
  status.resize(3);
  EXPECT_THAT(ParseStatus(status).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("3 bytes; expected 4")));
}

}  // namespace
}  // namespace transient::kinect2
