// The Kinect v2 stream parser and frame assembler on packet sequences built here from the
// stream's description (research/libusb.md §1.3): sub-packets of 298,648 bytes in iso packets of
// at most 33,792, zero-length packets between them; and every way a packet can go wrong.
#include "kinect2/stream_parser.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

namespace transient::kinect2 {
namespace {

constexpr size_t kPacket = 33792;

// A sub-packet: a sub-image whose bytes all equal `fill`, then the footer.
std::vector<uint8_t> SubPacket(uint32_t sequence, uint32_t sub, uint8_t fill,
                               uint32_t length = 298496) {
  std::vector<uint8_t> bytes(298496, fill);
  const uint32_t footer[6] = {0x12345678, 0x9ABCDEF0, 1000 + 266 * sequence + 26 * sub,
                              sequence, sub, length};
  for (uint32_t v : footer) {
    for (int i = 0; i < 4; ++i) bytes.push_back(static_cast<uint8_t>(v >> (8 * i)));
  }
  bytes.resize(bytes.size() + 128, 0);  // fields[32]
  return bytes;
}

// The packets of one sub-packet (8 x 33,792 + 28,312) and an idle zero-length one.
std::vector<std::vector<uint8_t>> Packets(const std::vector<uint8_t>& sub_packet,
                                          bool idle = true) {
  std::vector<std::vector<uint8_t>> packets;
  for (size_t at = 0; at < sub_packet.size(); at += kPacket) {
    const size_t n = std::min(kPacket, sub_packet.size() - at);
    packets.emplace_back(sub_packet.begin() + at, sub_packet.begin() + at + n);
  }
  if (idle) packets.emplace_back();
  return packets;
}

struct Harness {
  std::vector<SubFrame> subframes;
  std::vector<std::vector<SubFrame>> frames;
  FrameAssembler assembler{[this](std::vector<SubFrame>&& f) { frames.push_back(std::move(f)); }};
  StreamParser parser{[this](SubFrame&& s) {
    subframes.push_back(s);
    assembler.Add(std::move(s));
  }};
  void Feed(const std::vector<std::vector<uint8_t>>& packets) {
    for (const auto& p : packets) parser.Feed(IsoPacket{p, 0}, absl::Now());
  }
  void Frame(uint32_t sequence) {
    for (uint32_t sub = 0; sub < 10; ++sub) {
      Feed(Packets(SubPacket(sequence, sub, static_cast<uint8_t>(sequence * 10 + sub))));
    }
  }
};

TEST(StreamParser, WholeFramesBecomeTenSubFramesAndOneDepthFrame) {
  Harness h;
  h.Frame(7);
  h.Frame(8);
  ASSERT_EQ(h.subframes.size(), 20u);
  EXPECT_EQ(h.subframes[3].footer.sequence, 7u);
  EXPECT_EQ(h.subframes[3].footer.subsequence, 3u);
  EXPECT_EQ(h.subframes[3].footer.timestamp, 1000u + 266 * 7 + 26 * 3);
  EXPECT_EQ(h.subframes[3].payload.size(), kSubImageBytes);
  EXPECT_EQ(h.subframes[3].payload[12345], 73);
  ASSERT_EQ(h.frames.size(), 2u);
  ASSERT_EQ(h.frames[1].size(), 9u);  // sub-frames 0..8; 9 is not used
  for (uint32_t k = 0; k < 9; ++k) EXPECT_EQ(h.frames[1][k].footer.subsequence, k);
  EXPECT_EQ(h.assembler.counts().subframes_ninth, 2);
  EXPECT_EQ(h.parser.counts().subframes, 20);
  EXPECT_EQ(h.parser.counts().packets, 200);
  EXPECT_EQ(h.parser.counts().packet_errors + h.parser.counts().subpackets_short +
                h.parser.counts().bad_footers,
            0);
}

// libfreenect2 skips a failed packet without moving its offset on, so the rest of its transfer
// is read from the wrong place. Here every packet comes with its own bytes: a failed one loses
// its sub-packet only, and the next sub-packet is whole and right.
TEST(StreamParser, AFailedPacketLosesItsSubPacketOnlyAndTheNextIsRight) {
  Harness h;
  auto packets = Packets(SubPacket(1, 0, 10));
  auto next = Packets(SubPacket(1, 1, 11));
  for (size_t i = 0; i < packets.size(); ++i) {
    h.parser.Feed(IsoPacket{packets[i], i == 3 ? -71 /* EPROTO */ : 0}, absl::Now());
  }
  h.Feed(next);
  ASSERT_EQ(h.subframes.size(), 1u);
  EXPECT_EQ(h.subframes[0].footer.subsequence, 1u);
  EXPECT_EQ(h.subframes[0].payload.front(), 11);
  EXPECT_EQ(h.subframes[0].payload.back(), 11);
  EXPECT_EQ(h.parser.counts().packet_errors, 1);
  EXPECT_EQ(h.parser.counts().subpackets_lost, 1);
}

TEST(StreamParser, AFailedLastPacketResynchronisesAtTheNextIdlePacket) {
  Harness h;
  auto packets = Packets(SubPacket(1, 0, 10));
  for (size_t i = 0; i < packets.size(); ++i) {
    h.parser.Feed(IsoPacket{packets[i], i == 8 ? -18 /* EXDEV */ : 0}, absl::Now());
  }
  h.Feed(Packets(SubPacket(1, 1, 11)));
  ASSERT_EQ(h.subframes.size(), 1u);
  EXPECT_EQ(h.subframes[0].footer.subsequence, 1u);
}

TEST(StreamParser, ShortAndZeroLengthPacketsEndTheirSubPacket) {
  Harness h;
  auto short_packets = Packets(SubPacket(1, 0, 10));
  short_packets[2].resize(kPacket / 2);  // half its data
  h.Feed(short_packets);
  auto zero = Packets(SubPacket(1, 1, 11));
  zero.insert(zero.begin() + 4, std::vector<uint8_t>{});  // an idle packet inside a sub-packet
  h.Feed(zero);
  h.Feed(Packets(SubPacket(1, 2, 12)));
  ASSERT_EQ(h.subframes.size(), 1u);
  EXPECT_EQ(h.subframes[0].footer.subsequence, 2u);
  EXPECT_EQ(h.subframes[0].payload[100], 12);
  EXPECT_GE(h.parser.counts().subpackets_short, 2);
}

TEST(StreamParser, TooLongSubPacketsAndWrongFootersAreDropped) {
  Harness h;
  auto longer = Packets(SubPacket(1, 0, 10), /*idle=*/false);
  longer.insert(longer.begin(), std::vector<uint8_t>(kPacket, 1));  // one packet too many
  longer.emplace_back();
  h.Feed(longer);
  h.Feed(Packets(SubPacket(1, 1, 11, /*length=*/298495)));  // footer: wrong length
  h.Feed(Packets(SubPacket(1, 10, 11)));                    // footer: no sub-frame 10
  h.Feed(Packets(SubPacket(1, 3, 13)));
  ASSERT_EQ(h.subframes.size(), 1u);
  EXPECT_EQ(h.subframes[0].footer.subsequence, 3u);
  EXPECT_EQ(h.parser.counts().subpackets_too_long, 1);
  EXPECT_EQ(h.parser.counts().bad_footers, 2);
}

TEST(FrameAssembler, AFrameWithASubFrameMissingIsDroppedWholeAndTheNextComes) {
  Harness h;
  for (uint32_t sub = 0; sub < 10; ++sub) {
    if (sub == 4) continue;  // lost
    h.Feed(Packets(SubPacket(5, sub, 1)));
  }
  h.Frame(6);
  ASSERT_EQ(h.frames.size(), 1u);
  EXPECT_EQ(h.frames[0][0].footer.sequence, 6u);
  EXPECT_EQ(h.assembler.counts().frames_incomplete, 1);
  EXPECT_EQ(h.assembler.counts().frames, 1);
}

TEST(FrameAssembler, ASubFrameOlderThanTheLastFrameIsStrayAndCostsNothing) {
  Harness h;
  h.Frame(6);
  h.Feed(Packets(SubPacket(7, 0, 1)));
  h.Feed(Packets(SubPacket(5, 3, 1)));  // from before frame 6
  for (uint32_t sub = 1; sub < 10; ++sub) h.Feed(Packets(SubPacket(7, sub, 1)));
  ASSERT_EQ(h.frames.size(), 2u);
  EXPECT_EQ(h.frames[1][0].footer.sequence, 7u);
  EXPECT_EQ(h.assembler.counts().subframes_stray, 1);
  EXPECT_EQ(h.assembler.counts().frames_incomplete, 0);
}

TEST(FrameAssembler, DuplicatesAndLateSubFramesAreStray) {
  Harness h;
  h.Feed(Packets(SubPacket(5, 0, 1)));
  h.Feed(Packets(SubPacket(5, 0, 1)));  // twice: the frame cannot be trusted
  h.Frame(6);
  h.Feed(Packets(SubPacket(6, 2, 1)));  // after its frame was delivered
  ASSERT_EQ(h.frames.size(), 1u);
  EXPECT_EQ(h.frames[0][0].footer.sequence, 6u);
  EXPECT_EQ(h.assembler.counts().subframes_stray, 2);
}

}  // namespace
}  // namespace transient::kinect2
