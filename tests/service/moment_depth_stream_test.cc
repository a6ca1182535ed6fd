// MOMENT_DEPTH over real gRPC on loopback (issue 7): the daemon's moment depth map arrives,
// decodes, equals the map a client builds from the same frame's DEPTH, and answers occlusion
// queries for a virtual object as a depth test of that frame would; bad requests are refused
// naming the field while the daemon goes on.
#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <vector>

#include "absl/strings/str_cat.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "tests/service/daemon_fixture.h"
#include "tests/support/status_matchers.h"
#include "transient/reconstruct/moment_depth_map.h"
#include "transient/reconstruct/physical_constants.h"
#include "transient/wire/grpc_status.h"
#include "transient/wire/image_codec.h"
#include "transient/v1/transient.grpc.pb.h"

namespace transient::service {
namespace {

using ::transient::wire::FromGrpcStatus;
using ::transient::wire::DecodeImage;
using ::transient::wire::DecodeMomentDepth;

using ::testing::HasSubstr;
using ::transient::service::testing::Daemon;
using ::transient::service::testing::kSmallSim;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

constexpr ImageGeometry kSensor{32, 24};
const double kUnambiguousRangeM = UnambiguousRange(23e6);

// The first frame with images of a stream, or the status the stream ended with.
absl::StatusOr<v1::Frame> FirstFrame(v1::Transient::Stub& stub, const v1::StreamRequest& request) {
  grpc::ClientContext context;
  context.set_deadline(absl::ToChronoTime(absl::Now() + absl::Seconds(30)));
  std::unique_ptr<grpc::ClientReader<v1::Frame>> reader = stub.StreamFrames(&context, request);
  v1::Frame frame;
  while (reader->Read(&frame)) {
    if (frame.images_size() == 0) continue;
    context.TryCancel();
    (void)reader->Finish();
    return frame;
  }
  return FromGrpcStatus(reader->Finish());
}

std::map<std::string, v1::Image> ImagesByName(const v1::Frame& frame) {
  std::map<std::string, v1::Image> images;
  for (const v1::Image& image : frame.images()) images[image.name()] = image;
  return images;
}

v1::StreamRequest MomentRequest(bool with_depth) {
  v1::StreamRequest request;
  request.add_products(v1::MOMENT_DEPTH);
  if (with_depth) request.add_products(v1::DEPTH);
  return request;
}

TEST(MomentDepthStream, DefaultsAre64BitsOneSigmaAndTheUnambiguousRange) {
  Daemon daemon(kSmallSim);
  absl::StatusOr<v1::Frame> frame = FirstFrame(*daemon.Stub(), MomentRequest(false));
  ASSERT_THAT(frame.status(), IsOk());
  ASSERT_EQ(frame->images_size(), 1);
  const v1::Image& image = frame->images(0);
  EXPECT_EQ(image.name(), "moment_depth");
  EXPECT_EQ(image.product(), v1::MOMENT_DEPTH);
  EXPECT_EQ(image.encoding(), "16UC4");
  EXPECT_EQ(image.step(), 32u * 8u);
  ASSERT_TRUE(image.has_moment_depth());
  const v1::MomentDepthInfo& info = image.moment_depth();
  EXPECT_EQ(info.bits(), 64u);
  EXPECT_DOUBLE_EQ(info.near_m(), 0.0);
  EXPECT_NEAR(info.far_m(), kUnambiguousRangeM, 1e-9);
  EXPECT_DOUBLE_EQ(info.sigma_px(), 1.0);
  EXPECT_FALSE(info.from_returns());
  EXPECT_DOUBLE_EQ(info.bias_alpha(), kQuantized16MomentBias.alpha);
  EXPECT_DOUBLE_EQ(info.bias_b_star(), kQuantized16MomentBias.b_star_even);
}

// The daemon's map is the library's map of the DEPTH it sends in the same frame: the wire adds
// nothing and loses nothing (64-bit codes equal, one Gaussian of sigma 1.5).
TEST(MomentDepthStream, MapEqualsTheLibrarysMapOfTheSameFramesDepth) {
  Daemon daemon(kSmallSim);
  v1::StreamRequest request = MomentRequest(true);
  request.mutable_moment_depth()->set_near_m(0.5);
  request.mutable_moment_depth()->set_far_m(6.0);
  request.mutable_moment_depth()->set_sigma_px(1.5);
  request.set_compression(v1::ZSTD);
  absl::StatusOr<v1::Frame> frame = FirstFrame(*daemon.Stub(), request);
  ASSERT_THAT(frame.status(), IsOk());
  std::map<std::string, v1::Image> images = ImagesByName(*frame);
  ASSERT_EQ(images.count("moment_depth"), 1u);
  ASSERT_EQ(images.count("depth"), 1u);
  absl::StatusOr<MomentDepthMap> received = DecodeMomentDepth(images["moment_depth"]);
  ASSERT_THAT(received.status(), IsOk());
  absl::StatusOr<std::vector<float>> depth = DecodeImage(images["depth"]);
  ASSERT_THAT(depth.status(), IsOk());

  absl::StatusOr<MomentDepthMapBuilder> builder = MomentDepthMapBuilder::Create(
      kSensor, {.normalisation = {.near_m = 0.5, .far_m = 6.0}, .sigma_px = 1.5});
  ASSERT_THAT(builder.status(), IsOk());
  MomentDepthMap local;
  ASSERT_THAT(builder->Build(*depth, &local), IsOk());
  EXPECT_EQ(received->geometry, kSensor);
  EXPECT_EQ(received->quantized, local.quantized);
  EXPECT_EQ(static_cast<int64_t>(images["moment_depth"].moment_depth().empty_pixels()),
            local.empty_texels);
}

// A virtual plane facing the camera at the median depth of the scene: with no blur, the 128-bit
// map hides it exactly where the frame's depth lies in front of it, and shows it where the
// scene is behind. The margin keeps away from depths within the bias's reach of the plane.
TEST(MomentDepthStream, UnblurredMapOccludesAVirtualPlaneLikeADepthTest) {
  Daemon daemon(kSmallSim);
  v1::StreamRequest request = MomentRequest(true);
  request.mutable_moment_depth()->set_near_m(0.5);
  request.mutable_moment_depth()->set_far_m(6.0);
  request.mutable_moment_depth()->set_sigma_px(0.0);
  request.mutable_moment_depth()->set_bits(128);
  absl::StatusOr<v1::Frame> frame = FirstFrame(*daemon.Stub(), request);
  ASSERT_THAT(frame.status(), IsOk());
  std::map<std::string, v1::Image> images = ImagesByName(*frame);
  EXPECT_EQ(images["moment_depth"].encoding(), "32FC4");
  absl::StatusOr<MomentDepthMap> map = DecodeMomentDepth(images["moment_depth"]);
  ASSERT_THAT(map.status(), IsOk());
  absl::StatusOr<std::vector<float>> depth = DecodeImage(images["depth"]);
  ASSERT_THAT(depth.status(), IsOk());

  std::vector<float> valid;
  for (float d : *depth) {
    if (std::isfinite(d)) valid.push_back(d);
  }
  ASSERT_GT(valid.size(), depth->size() / 2);
  // The mirrors scene is mostly a back wall (median 2.18 m, 90th percentile 2.50 m, measured):
  // the plane goes halfway between the median and the 90th percentile.
  std::sort(valid.begin(), valid.end());
  const double plane_m = 0.5 * (valid[valid.size() / 2] + valid[valid.size() * 9 / 10]);
  constexpr double kMarginM = 0.05;  // 1.8% of the 5.5 m range: far beyond the bias's reach
  int in_front = 0, behind = 0;
  for (int y = 0; y < kSensor.height; ++y) {
    for (int x = 0; x < kSensor.width; ++x) {
      const float d = (*depth)[y * kSensor.width + x];
      const float occlusion = map->Occlusion(x, y, plane_m);
      ASSERT_TRUE(std::isfinite(occlusion));
      if (!std::isfinite(d)) {
        EXPECT_EQ(occlusion, 0.0f) << "an invalid pixel hides nothing, at " << x << "," << y;
      } else if (d < plane_m - kMarginM) {
        ++in_front;
        EXPECT_GT(occlusion, 0.99f) << "scene at " << d << " m in front, at " << x << "," << y;
      } else if (d > plane_m + kMarginM) {
        ++behind;
        EXPECT_LT(occlusion, 0.01f) << "scene at " << d << " m behind, at " << x << "," << y;
      }
    }
  }
  EXPECT_GT(in_front, 50);
  EXPECT_GT(behind, 50);
}

// With the moments of the Pisarenko returns, a plane in front of every return is visible, and
// one behind the last is hidden wherever the pixel had returns, up to the slack of a lower
// bound: Hamburger 4MSM does not know that depths stop at the far plane, so a pixel whose
// returns spread over the range may leave up to a few percent "possibly behind" (measured
// 0.989 on three-return pixels of this scene).
TEST(MomentDepthStream, MapFromReturnsBoundsAPlaneBeforeAndBehindTheScene) {
  Daemon daemon(kSmallSim);
  v1::StreamRequest request = MomentRequest(false);
  request.mutable_moment_depth()->set_from_returns(true);
  request.mutable_moment_depth()->set_sigma_px(0.0);
  request.mutable_moment_depth()->set_bits(128);
  request.mutable_roi()->set_x(8);
  request.mutable_roi()->set_y(4);
  request.mutable_roi()->set_width(16);
  request.mutable_roi()->set_height(12);
  absl::StatusOr<v1::Frame> frame = FirstFrame(*daemon.Stub(), request);
  ASSERT_THAT(frame.status(), IsOk());
  ASSERT_EQ(frame->images_size(), 1);
  EXPECT_TRUE(frame->images(0).moment_depth().from_returns());
  absl::StatusOr<MomentDepthMap> map = DecodeMomentDepth(frame->images(0));
  ASSERT_THAT(map.status(), IsOk());
  EXPECT_EQ(map->geometry, (ImageGeometry{16, 12}));
  int hidden = 0;
  for (int y = 0; y < 12; ++y) {
    for (int x = 0; x < 16; ++x) {
      EXPECT_LT(map->Occlusion(x, y, 0.01), 0.01f) << x << "," << y;
      const float far = map->Occlusion(x, y, kUnambiguousRangeM);
      EXPECT_TRUE(far < 0.01f || far > 0.95f) << far << " at " << x << "," << y << ", texel "
                                              << ::testing::PrintToString(map->Texel(x, y));
      hidden += far > 0.95f;
    }
  }
  EXPECT_GT(hidden, 16 * 12 / 2);
}

TEST(MomentDepthStream, BadRequestsAreRefusedNamingTheFieldAndOthersGoOn) {
  Daemon daemon(kSmallSim);
  auto expect_invalid = [&](auto&& change, const std::string& message) {
    v1::StreamRequest request = MomentRequest(false);
    change(request.mutable_moment_depth());
    EXPECT_THAT(FirstFrame(*daemon.Stub(), request).status(),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(message)))
        << request.ShortDebugString();
  };
  expect_invalid([](v1::MomentDepthRequest* r) { r->set_near_m(-1.0); r->set_far_m(2.0); },
                 "moment_depth.near_m = -1");
  expect_invalid([](v1::MomentDepthRequest* r) { r->set_near_m(2.0); r->set_far_m(1.0); },
                 "moment_depth.far_m = 1");
  expect_invalid([](v1::MomentDepthRequest* r) { r->set_near_m(1.0); r->set_far_m(NAN); },
                 "moment_depth.far_m = nan");
  expect_invalid([](v1::MomentDepthRequest* r) { r->set_bits(32); }, "moment_depth.bits = 32");
  expect_invalid([](v1::MomentDepthRequest* r) { r->set_sigma_px(-1.0); }, "sigma");
  expect_invalid([](v1::MomentDepthRequest* r) { r->set_sigma_px(100.0); }, "moment_depth: ");

  // Eight different maps at once are served; a ninth is refused, and the eight go on.
  std::vector<std::unique_ptr<v1::Transient::Stub>> stubs;
  std::vector<std::unique_ptr<grpc::ClientContext>> contexts;
  std::vector<std::unique_ptr<grpc::ClientReader<v1::Frame>>> readers;
  for (int i = 0; i < kMaxMomentDepthSpecs; ++i) {
    v1::StreamRequest request = MomentRequest(false);
    request.mutable_moment_depth()->set_sigma_px(0.25 * i);
    stubs.push_back(daemon.Stub());
    contexts.push_back(std::make_unique<grpc::ClientContext>());
    readers.push_back(stubs.back()->StreamFrames(contexts.back().get(), request));
  }
  ASSERT_TRUE(daemon.WaitForSubscribers(kMaxMomentDepthSpecs));
  v1::StreamRequest ninth = MomentRequest(false);
  ninth.mutable_moment_depth()->set_sigma_px(3.0);
  EXPECT_THAT(FirstFrame(*daemon.Stub(), ninth).status(),
              StatusIs(absl::StatusCode::kResourceExhausted, HasSubstr("at most 8")));
  for (size_t i = 0; i < readers.size(); ++i) {
    v1::Frame frame;
    ASSERT_TRUE(readers[i]->Read(&frame)) << "stream " << i;
    while (frame.images_size() == 0 && readers[i]->Read(&frame)) {
    }
    ASSERT_EQ(frame.images_size(), 1) << "stream " << i;
    EXPECT_DOUBLE_EQ(frame.images(0).moment_depth().sigma_px(), 0.25 * i);
    contexts[i]->TryCancel();
  }
  for (auto& reader : readers) {
    v1::Frame frame;
    while (reader->Read(&frame)) {
    }
    (void)reader->Finish();
  }
}

}  // namespace
}  // namespace transient::service
