// The gateway's messages (web/): the binary frame message against the layout documented in
// frame_message.h, read back here byte by byte, and the page's JSON requests, good and bad.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>

#include "absl/strings/str_cat.h"
#include "tests/support/status_matchers.h"
#include "transient/v1/transient.pb.h"
#include "transient/web/frame_message.h"
#include "transient/web/page_request.h"
#include "transient/wire/image_codec.h"

namespace transient::web {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;
constexpr auto kInvalid = absl::StatusCode::kInvalidArgument;

client::DecodedImage Image(const std::string& name, wire::ImageKind kind, std::vector<float> v) {
  client::DecodedImage image;
  image.name = name;
  image.kind = kind;
  image.unit = kind == wire::ImageKind::kRange ? "m" : "";
  image.geometry = {3, 2};
  image.values = std::move(v);
  return image;
}

uint32_t ReadUint32(const std::string& bytes, size_t at) {
  uint32_t value = 0;
  for (int i = 0; i < 4; ++i) value |= uint32_t{static_cast<uint8_t>(bytes[at + i])} << (8 * i);
  return value;
}

TEST(FrameMessage, HalfFloatsAndBytesAtTheOffsetsTheHeaderGives) {
  client::StreamFrame frame;
  frame.sequence = 42;
  frame.capture_time_s = 1.5;
  frame.latency_s = 0.02;
  frame.missed = 3;
  frame.images.push_back(
      Image("range", wire::ImageKind::kRange, {1.0f, 2.5f, NAN, 0.0f, -1.0f, 65504.0f}));
  frame.images.push_back(Image("flags", wire::ImageKind::kFlags, {0, 4, 1, 255, 6, 2}));
  client::DecodedImage slice = Image("slices/3", wire::ImageKind::kSlice, {0, 0, 0, 0, 0, 0.25f});
  slice.time_of_flight_ns = 4.35;
  frame.images.push_back(slice);

  const std::string message = EncodeFrameMessage(frame);
  ASSERT_GE(message.size(), 8u);
  EXPECT_EQ(message.substr(0, 4), "TRF1");
  const uint32_t header_length = ReadUint32(message, 4);
  EXPECT_EQ(header_length % 4, 0u);
  const std::string header = message.substr(8, header_length);
  EXPECT_THAT(header, HasSubstr("\"sequence\":42"));
  EXPECT_THAT(header, HasSubstr("\"missed\":3"));
  EXPECT_THAT(header, HasSubstr("\"latencyMs\":20"));
  EXPECT_THAT(header, HasSubstr("\"width\":3,\"height\":2"));
  EXPECT_THAT(
      header,
      HasSubstr("{\"name\":\"range\",\"unit\":\"m\",\"type\":\"f16\",\"offset\":0,\"length\":12}"));
  // 12 bytes of range, then the flags' 6 bytes padded to 8: the slice starts at 20.
  EXPECT_THAT(header, HasSubstr("{\"name\":\"flags\",\"unit\":\"\",\"type\":\"u8\",\"offset\":12,"
                                "\"length\":6}"));
  EXPECT_THAT(header,
              HasSubstr("\"name\":\"slices/3\",\"unit\":\"\",\"type\":\"f16\",\"offset\":20,"
                        "\"length\":12,\"tofNs\":4.35}"));
  const size_t payload = 8 + header_length;
  ASSERT_EQ(message.size(), payload + 32);
  auto half = [&](size_t at) {
    return wire::HalfToFloat(static_cast<uint16_t>(static_cast<uint8_t>(message[at]) |
                                                   static_cast<uint8_t>(message[at + 1]) << 8));
  };
  EXPECT_EQ(half(payload + 0), 1.0f);
  EXPECT_EQ(half(payload + 2), 2.5f);
  EXPECT_TRUE(std::isnan(half(payload + 4)));
  EXPECT_EQ(half(payload + 8), -1.0f);
  EXPECT_EQ(half(payload + 10), 65504.0f);
  EXPECT_EQ(static_cast<uint8_t>(message[payload + 12 + 1]), 4);
  EXPECT_EQ(static_cast<uint8_t>(message[payload + 12 + 3]), 255);
  EXPECT_EQ(half(payload + 20 + 10), 0.25f);
}

TEST(FrameMessage, ImagesOfSeveralValuesPerPixelAreLeftOut) {
  client::StreamFrame frame;
  frame.images.push_back(
      Image("moment_depth", wire::ImageKind::kMomentDepth, std::vector<float>(24, 1.0f)));
  const std::string message = EncodeFrameMessage(frame);
  EXPECT_THAT(message.substr(8, ReadUint32(message, 4)), HasSubstr("\"images\":[]"));
  EXPECT_EQ(message.size(), 8 + ReadUint32(message, 4));
}

TEST(PageRequest, AGoodRequestParsesIntoItsMethodsMessage) {
  uint64_t id = 0;
  absl::StatusOr<PageRequest> request = ParsePageRequest(
      R"({"id": 7, "method": "SetConfig", "request": {"threshold": 0.2, "rangeMethod": "PISARENKO"}})",
      &id);
  ASSERT_THAT(request.status(), IsOk());
  EXPECT_EQ(id, 7u);
  EXPECT_EQ(request->method, "SetConfig");
  const auto& config = static_cast<const v1::Config&>(*request->request);
  EXPECT_EQ(config.threshold(), 0.2);
  EXPECT_EQ(config.range_method(), v1::PISARENKO);
  EXPECT_FALSE(config.has_bias_epsilon());

  // The request may be left out when its message has no field to set.
  request = ParsePageRequest(R"({"id": 1, "method": "GetStats"})", &id);
  ASSERT_THAT(request.status(), IsOk());
  EXPECT_EQ(request->method, "GetStats");
}

TEST(PageRequest, BadRequestsAreRefusedNamingWhatIsWrong) {
  uint64_t id = 99;
  EXPECT_THAT(ParsePageRequest("", &id).status(), StatusIs(kInvalid, HasSubstr("JSON object")));
  EXPECT_EQ(id, 0u);
  EXPECT_THAT(ParsePageRequest("[1, 2]", &id).status(), StatusIs(kInvalid, HasSubstr("JSON")));
  EXPECT_THAT(ParsePageRequest("{\"id\": 1, \"method\": \"GetStats\"", &id).status(),
              StatusIs(kInvalid, HasSubstr("JSON")));
  EXPECT_THAT(ParsePageRequest(R"({"method": "GetStats"})", &id).status(),
              StatusIs(kInvalid, HasSubstr("id: missing")));
  for (const char* bad_id : {"0", "-3", "1.5", "\"7\"", "9007199254740992", "1e300", "null"}) {
    EXPECT_THAT(ParsePageRequest(absl::StrCat(R"({"method": "GetStats", "id": )", bad_id, "}"), &id)
                    .status(),
                StatusIs(kInvalid, HasSubstr("id: a whole number")))
        << bad_id;
  }
  EXPECT_THAT(ParsePageRequest(R"({"id": 5, "method": "DeleteEverything"})", &id).status(),
              StatusIs(kInvalid, HasSubstr("'DeleteEverything' is not one of")));
  EXPECT_EQ(id, 5u);  // kept, so that the refusal reaches its caller
  EXPECT_THAT(ParsePageRequest(R"({"id": 5, "method": 3})", &id).status(),
              StatusIs(kInvalid, HasSubstr("method: missing, or not a string")));
  EXPECT_THAT(ParsePageRequest(R"({"id": 5, "method": "GetPixel", "extra": 1})", &id).status(),
              StatusIs(kInvalid, HasSubstr("'extra' is not a field")));
  EXPECT_THAT(ParsePageRequest(R"({"id": 5, "method": "GetPixel", "request": 4})", &id).status(),
              StatusIs(kInvalid, HasSubstr("request: not an object")));
  EXPECT_THAT(
      ParsePageRequest(R"({"id": 5, "method": "GetPixel", "request": {"z": 1}})", &id).status(),
      StatusIs(kInvalid, HasSubstr("request of GetPixel")));
  EXPECT_THAT(ParsePageRequest(R"({"id": 5, "method": "GetPixel", "request": {"x": "left"}})", &id)
                  .status(),
              StatusIs(kInvalid, HasSubstr("request of GetPixel")));
  EXPECT_THAT(ParsePageRequest(std::string(kMaxPageRequestBytes + 1, ' '), &id).status(),
              StatusIs(kInvalid, HasSubstr("at most")));
  // Found by the page_request fuzz harness: a method name that is not UTF-8 came back quoted
  // in the refusal, which was then no text a browser accepts.
  for (const char* bad : {"{\"id\": 1, \"method\": \"G\xc0\xa5\"}", "\xff", "\xed\xa0\x80",
                          "\xf4\x90\x80\x80", "\xe2\x82"}) {
    EXPECT_THAT(ParsePageRequest(bad, &id).status(), StatusIs(kInvalid, HasSubstr("UTF-8"))) << bad;
  }
  EXPECT_THAT(
      ParsePageRequest("{\"id\": 1, \"method\": \"\xc3\xa9\xe2\x82\xac\xf0\x9f\x98\x80\"}", &id)
          .status(),
      StatusIs(kInvalid, HasSubstr("is not one of")));  // UTF-8, just not a method
}

TEST(PageRequest, RepliesAreJsonWithTheDaemonsWords) {
  v1::Config config;
  config.set_threshold(0.25);
  EXPECT_THAT(ReplyResult(3, config), HasSubstr(R"({"id":3,"ok":true,"result":{)"));
  EXPECT_THAT(ReplyResult(3, config), HasSubstr(R"("threshold":0.25)"));
  // (The order of the error's and the news' fields is protobuf's: not part of the contract.)
  const std::string error = ReplyError(4, absl::InvalidArgumentError("threshold = 5 \"bad\""));
  EXPECT_THAT(error, HasSubstr(R"({"id":4,"ok":false,"error":{)"));
  EXPECT_THAT(error, HasSubstr(R"("code":"INVALID_ARGUMENT")"));
  EXPECT_THAT(error, HasSubstr(R"("message":"threshold = 5 \"bad\"")"));
  EXPECT_EQ(ReplyProgress(5, 2, 20), R"({"id":5,"progress":{"done":2,"total":20}})");
  const std::string news = DaemonNews(false, "gone");
  EXPECT_THAT(news, HasSubstr(R"({"news":"daemon","body":{)"));
  EXPECT_THAT(news, HasSubstr(R"("connected":false)"));
  EXPECT_THAT(news, HasSubstr(R"("message":"gone")"));
}

}  // namespace
}  // namespace transient::web
