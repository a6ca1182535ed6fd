// The NATS side of the wire codec without a server: names, server lists, user files, and a
// frame cut into parts and joined again, with the bad inputs a consumer may receive.
#include "transient/wire/nats.h"

#include <sys/stat.h>

#include <fstream>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "transient/wire/credentials.h"

namespace transient::wire {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;

v1::Frame FrameOf(uint64_t sequence, size_t bytes) {
  v1::Frame frame;
  frame.set_sequence(sequence);
  v1::Image* image = frame.add_images();
  image->set_name("range");
  image->set_data(std::string(bytes, static_cast<char>(sequence)));
  return frame;
}

TEST(NatsNames, SubjectsStreamsAndBadCameraNames) {
  EXPECT_EQ(NatsSubject("lab1", v1::MOMENT_STATE), "transient.lab1.moment_state");
  EXPECT_EQ(NatsCameraSubjects("lab1"), "transient.lab1.>");
  EXPECT_EQ(NatsStreamName("lab1"), "TRANSIENT_lab1");
  EXPECT_THAT(CheckNatsCameraName("rig_2-b"), IsOk());
  for (const char* bad : {"", "a.b", "a b", "a*", "a>", "ü"}) {
    EXPECT_EQ(CheckNatsCameraName(bad).code(), absl::StatusCode::kInvalidArgument) << bad;
  }
  EXPECT_FALSE(CheckNatsCameraName(std::string(65, 'a')).ok());
}

TEST(NatsServers, ListsAreParsedAndBadOnesNamed) {
  absl::StatusOr<std::vector<std::string>> servers =
      ParseNatsServers("nats://a:4222, tls://b:4223,nats://[::1]:1");
  ASSERT_THAT(servers.status(), IsOk());
  EXPECT_EQ(servers->size(), 3u);
  for (const char* bad : {"", ",", "a:4222", "http://a:4222", "nats://a", "nats://:4222",
                          "nats://a:0", "nats://a:65536", "nats://a:x"}) {
    const absl::Status status = ParseNatsServers(bad).status();
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << bad;
  }
  EXPECT_THAT(ParseNatsServers("nats://a:1,http://b:2").status().message(),
              HasSubstr("http://b:2"));
}

TEST(NatsUserFile, UserAndPasswordOrWhyNot) {
  ::transient::testing::ScratchDirectory dir;
  auto write = [&](const std::string& name, const std::string& text, mode_t mode = 0600) {
    std::ofstream(dir.File(name)) << text;
    ::chmod(dir.File(name).c_str(), mode);
    return dir.File(name);
  };
  absl::StatusOr<std::pair<std::string, std::string>> good =
      ReadUserPasswordFile("--nats-user-file", write("good", "camera:pa:ss\n"));
  ASSERT_THAT(good.status(), IsOk());
  EXPECT_EQ(good->first, "camera");
  EXPECT_EQ(good->second, "pa:ss");
  for (const auto& [name, text] : std::vector<std::pair<std::string, std::string>>{
           {"nocolon", "camera\n"}, {"nouser", ":secret\n"}, {"twolines", "a:b\nc:d\n"}}) {
    EXPECT_EQ(ReadUserPasswordFile("--nats-user-file", write(name, text)).status().code(),
              absl::StatusCode::kInvalidArgument)
        << name;
  }
  EXPECT_THAT(
      ReadUserPasswordFile("--nats-user-file", write("open", "a:b\n", 0644)).status().message(),
      HasSubstr("chmod 600"));
  EXPECT_FALSE(ReadUserPasswordFile("--nats-user-file", dir.File("missing")).ok());
  EXPECT_FALSE(CheckSecretFile("--nats-creds", write("creds", "x", 0644)).ok());
  EXPECT_THAT(CheckSecretFile("--nats-creds", write("creds2", "x")), IsOk());
}

TEST(NatsParts, AFrameCutIntoPartsIsJoinedAgain) {
  const v1::Frame frame = FrameOf(7, 1000);
  const std::vector<NatsPart> parts = SplitFrame(frame, 300);
  ASSERT_EQ(parts.size(), 4u);
  FrameAssembler assembler;
  v1::Frame joined;
  std::string error;
  for (size_t k = 0; k < parts.size(); ++k) {
    const auto result = assembler.Add(7, absl::StrCat(parts[k].index, "/", parts[k].count),
                                      parts[k].data, &joined, &error);
    EXPECT_EQ(result, k + 1 < parts.size() ? FrameAssembler::Result::kIncomplete
                                           : FrameAssembler::Result::kFrame);
  }
  EXPECT_EQ(joined.SerializeAsString(), frame.SerializeAsString());
  EXPECT_EQ(assembler.abandoned(), 0);
  // One message, without a part header: the frame itself.
  EXPECT_EQ(assembler.Add(8, "", FrameOf(8, 10).SerializeAsString(), &joined, &error),
            FrameAssembler::Result::kFrame);
  EXPECT_EQ(joined.sequence(), 8u);
}

TEST(NatsParts, MissingPartsAbandonTheFrameAndBadPartsAreRefused) {
  const std::vector<NatsPart> a = SplitFrame(FrameOf(1, 1000), 400);  // 3 parts
  const std::vector<NatsPart> b = SplitFrame(FrameOf(2, 1000), 400);
  FrameAssembler assembler;
  v1::Frame joined;
  std::string error;
  auto add = [&](uint64_t seq, const NatsPart& p) {
    return assembler.Add(seq, absl::StrCat(p.index, "/", p.count), p.data, &joined, &error);
  };
  // A consumer that starts in the middle of frame 1, then frame 1's part 1 of a lost run: frame
  // 2 still arrives whole.
  EXPECT_EQ(add(1, a[1]), FrameAssembler::Result::kIncomplete);
  EXPECT_EQ(add(1, a[2]), FrameAssembler::Result::kIncomplete);
  EXPECT_EQ(assembler.abandoned(), 1);
  EXPECT_EQ(add(2, b[0]), FrameAssembler::Result::kIncomplete);
  EXPECT_EQ(add(2, b[2]), FrameAssembler::Result::kIncomplete);  // b[1] lost
  EXPECT_EQ(assembler.abandoned(), 2);
  for (const NatsPart& p : b) add(2, p);
  EXPECT_EQ(joined.sequence(), 2u);
  // Headers that are not k/n with 1 <= k <= n.
  for (const char* bad : {"0/1", "2/1", "1/0", "x/2", "1/", "/", "1/99999999"}) {
    EXPECT_EQ(assembler.Add(3, bad, "", &joined, &error), FrameAssembler::Result::kBad) << bad;
    EXPECT_THAT(error, HasSubstr("Transient-Part")) << bad;
  }
  // Bytes that are not a frame.
  EXPECT_EQ(assembler.Add(4, "1/1", std::string("\xff\xff\xff\xff", 4), &joined, &error),
            FrameAssembler::Result::kBad);
  EXPECT_THAT(error, HasSubstr("not a transient.v1.Frame"));
}

TEST(NatsMessages, OneMessagePerProductWithItsImagesAndHeaders) {
  v1::Frame frame = FrameOf(5, 10);
  frame.mutable_images(0)->set_product(v1::RANGE);
  v1::Image* depth = frame.add_images();
  depth->set_product(v1::DEPTH);
  depth->set_name("depth");
  const std::vector<NatsMessage> messages =
      FrameMessages(frame, "cam", {v1::RANGE, v1::DEPTH}, "FLOAT32/NONE", 23e6, 1 << 20);
  ASSERT_EQ(messages.size(), 2u);
  EXPECT_EQ(messages[0].subject, "transient.cam.range");
  EXPECT_EQ(messages[1].subject, "transient.cam.depth");
  for (const NatsMessage& m : messages) {
    v1::Frame one;
    ASSERT_TRUE(one.ParseFromString(m.data));
    ASSERT_EQ(one.images_size(), 1);
    EXPECT_EQ(one.sequence(), 5u);
    EXPECT_THAT(m.headers, ::testing::Contains(
                               std::make_pair(std::string(kNatsPartHeader), std::string("1/1"))));
  }
}

}  // namespace
}  // namespace transient::wire
