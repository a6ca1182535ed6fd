// frame_stream.h against a real transientd in this process: every product decoded with the
// registry's names and units, millimetres arriving as metres, a refused request, an ended
// source, our own ends (early Finish, deadline, Cancel from another thread, the cancel flag),
// and a corrupt image from a fake, dropped and counted.
#include "transient/client/frame_stream.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "tests/client/connect.h"
#include "tests/client/fake_transient.h"
#include "tests/service/daemon_fixture.h"
#include "tests/support/status_matchers.h"
#include "tests/support/wait.h"
#include "transient/client/client.h"
#include "transient/reconstruct/moments.h"
#include "transient/wire/product_registry.h"

namespace transient::client {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::transient::service::testing::Daemon;
using ::transient::service::testing::kSmallSim;
using ::transient::service::testing::Request;
using ::transient::testing::IsOk;
using ::transient::testing::MustConnect;
using ::transient::testing::SecondsSince;
using ::transient::testing::StatusIs;

constexpr ImageGeometry kSimGeometry{32, 24};

// The next frame with images, skipping announcements; false when the stream ends first.
bool NextImages(FrameStream& stream, StreamFrame* frame) {
  while (stream.Next(frame)) {
    if (frame->kind == StreamFrame::Kind::kImages) return true;
  }
  return false;
}

// The daemon and the client agree through the registry: every image of every product arrives
// named as the registry names it, with its unit, its product's encoding and the stream's size.
// (Every product a schedule with all harmonics serves: CONFIDENCE is a harmonic set's.)
TEST(FrameStream, EveryProductArrivesDecodedWithTheRegistrysNamesAndUnits) {
  Daemon daemon(kSmallSim);
  const Client client = MustConnect(daemon.address());
  v1::StreamRequest request;
  std::vector<const wire::ProductSpec*> served;
  for (const wire::ProductSpec& spec : wire::Products()) {
    if (spec.needs == wire::ProductSpec::Needs::kHarmonicSet) continue;
    request.add_products(spec.product);
    served.push_back(&spec);
  }
  constexpr int kSlices = 4;
  request.mutable_slices()->set_bins(kSlices);
  request.mutable_roi()->set_x(2);
  request.mutable_roi()->set_y(1);
  request.mutable_roi()->set_width(20);
  request.mutable_roi()->set_height(10);
  std::unique_ptr<FrameStream> stream = client.StreamFrames(request);
  StreamFrame frame;
  ASSERT_TRUE(NextImages(*stream, &frame)) << stream->Finish();
  EXPECT_EQ(stream->counts().corrupt, 0) << stream->last_corruption();

  constexpr int kOrder = 3;  // the simulator's default schedule, m = 3
  std::map<v1::Product, int> images_of;
  std::set<std::string> names;
  for (const DecodedImage& image : frame.images) {
    SCOPED_TRACE(image.name);
    const wire::ImageSpec& spec = wire::Image(image.kind);
    EXPECT_EQ(spec.product, image.product);
    EXPECT_EQ(image.name, wire::ImageName(image.kind, image.index));
    EXPECT_EQ(image.unit, spec.unit);
    EXPECT_EQ(image.geometry, (ImageGeometry{20, 10}));
    EXPECT_EQ(image.values.size(), static_cast<size_t>(spec.channels * 200));
    EXPECT_TRUE(names.insert(image.name).second);
    ++images_of[image.product];
  }
  // Each product sent as many planes as the registry counts for its memory bound.
  for (const wire::ProductSpec* spec : served) {
    EXPECT_EQ(images_of[spec->product] *
                  (spec->product == v1::MOMENT_DEPTH ? 4 : 1),  // one image of four channels
              wire::PlanesPerFrame(spec->product, kOrder, kSlices))
        << spec->name;
  }
  EXPECT_TRUE(names.contains("slices/3"));
  EXPECT_TRUE(names.contains("c_imag/1"));
  EXPECT_FALSE(names.contains("c_imag/0"));
  EXPECT_TRUE(names.contains("q_imag/0"));
  EXPECT_THAT(stream->Finish(), IsOk());  // ours to end: not an error
}

TEST(FrameStream, MillimetreDepthArrivesInMetres) {
  Daemon daemon(kSmallSim);
  const Client client = MustConnect(daemon.address());
  v1::StreamRequest request = Request({v1::DEPTH});
  request.set_encoding(v1::UINT16_MM);
  std::unique_ptr<FrameStream> stream = client.StreamFrames(request);
  StreamFrame frame;
  ASSERT_TRUE(NextImages(*stream, &frame)) << stream->Finish();
  ASSERT_EQ(frame.images.size(), 1u);
  const DecodedImage& depth = frame.images[0];
  EXPECT_EQ(depth.kind, wire::ImageKind::kDepth);
  EXPECT_EQ(depth.unit, "m");  // "mm" on the wire
  EXPECT_EQ(depth.geometry, kSimGeometry);
  int finite = 0;
  for (float z : depth.values) {
    if (std::isnan(z)) continue;  // 0 mm: invalid
    ++finite;
    EXPECT_GT(z, 0.5f);
    EXPECT_LT(z, 7.0f);
    EXPECT_EQ(std::round(z * 1000.0f), z * 1000.0f) << "whole millimetres";
  }
  EXPECT_GT(finite, kSimGeometry.pixel_count() / 2);
}

TEST(FrameStream, FramesCarryTheirSequenceLatencyAndMissedCount) {
  Daemon daemon(kSmallSim);
  const Client client = MustConnect(daemon.address());
  std::unique_ptr<FrameStream> stream = client.StreamFrames(Request({v1::RANGE}));
  StreamFrame first, second;
  ASSERT_TRUE(NextImages(*stream, &first));
  ASSERT_TRUE(NextImages(*stream, &second));
  EXPECT_LT(first.sequence, second.sequence);
  EXPECT_LE(first.arrival, second.arrival);
  // The daemon's reconstruction time plus the loopback: positive, never seconds.
  EXPECT_GT(second.latency_s, 0.0);
  EXPECT_LT(second.latency_s, 5.0);
  EXPECT_EQ(stream->counts().frames, 2);
  EXPECT_EQ(stream->counts().missed, first.missed + second.missed);
  EXPECT_THAT(stream->Finish(), IsOk());
  EXPECT_FALSE(stream->Next(&first));  // finished: nothing more
  EXPECT_THAT(stream->Finish(), IsOk());  // the same status again
}

TEST(FrameStream, BadRequestsEndTheStreamWithTheDaemonsInvalidArgument) {
  Daemon daemon(kSmallSim);
  const Client client = MustConnect(daemon.address());
  std::unique_ptr<FrameStream> unknown = client.StreamFrames(Request({static_cast<v1::Product>(42)}));
  StreamFrame frame;
  EXPECT_FALSE(unknown->Next(&frame));
  EXPECT_THAT(unknown->Finish(), StatusIs(absl::StatusCode::kInvalidArgument,
                                          HasSubstr("products: unknown product 42; expected "
                                                    "RANGE, DEPTH, AMPLITUDE")));
  v1::StreamRequest millimetre_slices = Request({v1::SLICES});
  millimetre_slices.set_encoding(v1::UINT16_MM);
  std::unique_ptr<FrameStream> slices = client.StreamFrames(millimetre_slices);
  EXPECT_FALSE(slices->Next(&frame));
  EXPECT_THAT(slices->Finish(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("UINT16_MM (millimetres) only for the lengths RANGE and DEPTH")));
  EXPECT_EQ(slices->counts().frames, 0);
  // The daemon goes on serving good requests.
  std::unique_ptr<FrameStream> good = client.StreamFrames(Request({v1::RANGE}));
  EXPECT_TRUE(NextImages(*good, &frame));
}

TEST(FrameStream, AnEndedSourceIsAnnouncedAndEndsTheStreamWithOutOfRange) {
  // Three frames, then the simulator ends; the pipeline starts once we are subscribed, so that
  // all three reach us.
  Daemon daemon("sim:mirrors?width=32&height=24&frames=3", /*start=*/false);
  const Client client = MustConnect(daemon.address());
  std::unique_ptr<FrameStream> stream = client.StreamFrames(Request({v1::RANGE}));
  ASSERT_TRUE(daemon.WaitForSubscribers(1));
  daemon.pipeline().Start();
  std::vector<StreamFrame::Kind> kinds;
  StreamFrame frame;
  while (stream->Next(&frame)) kinds.push_back(frame.kind);
  EXPECT_THAT(kinds, ::testing::ElementsAre(StreamFrame::Kind::kImages,
                                            StreamFrame::Kind::kImages,
                                            StreamFrame::Kind::kImages,
                                            StreamFrame::Kind::kAnnouncement));
  EXPECT_EQ(frame.state, v1::ENDED);
  EXPECT_EQ(stream->counts().announcements, 1);
  EXPECT_THAT(stream->Finish(), StatusIs(absl::StatusCode::kOutOfRange,
                                         HasSubstr("ended after 3 frames to this client")));
}

TEST(FrameStream, CancelFromAnotherThreadEndsABlockedNext) {
  Daemon daemon(kSmallSim, /*start=*/false);  // never a frame: Next blocks
  const Client client = MustConnect(daemon.address());
  std::unique_ptr<FrameStream> stream = client.StreamFrames(Request({v1::RANGE}));
  std::thread canceller([&stream] {
    absl::SleepFor(absl::Milliseconds(200));
    stream->Cancel();
  });
  const auto start = std::chrono::steady_clock::now();
  StreamFrame frame;
  EXPECT_FALSE(stream->Next(&frame));
  EXPECT_LT(SecondsSince(start), 10.0);
  canceller.join();
  EXPECT_THAT(stream->Finish(),
              StatusIs(absl::StatusCode::kCancelled,
                       HasSubstr("stream from transientd at " + daemon.address() + " cancelled")));
}

TEST(FrameStream, TheCancelFlagEndsABlockedNext) {
  Daemon daemon(kSmallSim, /*start=*/false);
  const Client client = MustConnect(daemon.address());
  std::atomic<bool> cancel{false};
  std::unique_ptr<FrameStream> stream =
      client.StreamFrames(Request({v1::RANGE}), {.cancel = &cancel});
  std::thread canceller([&cancel] {
    absl::SleepFor(absl::Milliseconds(200));
    cancel = true;  // as a signal handler would
  });
  StreamFrame frame;
  EXPECT_FALSE(stream->Next(&frame));
  canceller.join();
  EXPECT_THAT(stream->Finish(), StatusIs(absl::StatusCode::kCancelled, HasSubstr("cancelled")));
}

TEST(FrameStream, TheDeadlineEndsTheStreamWithoutAnError) {
  Daemon daemon(kSmallSim, /*start=*/false);
  const Client client = MustConnect(daemon.address());
  const auto start = std::chrono::steady_clock::now();
  std::unique_ptr<FrameStream> stream = client.StreamFrames(
      Request({v1::RANGE}), {.deadline = absl::Now() + absl::Milliseconds(300)});
  StreamFrame frame;
  EXPECT_FALSE(stream->Next(&frame));
  EXPECT_GE(SecondsSince(start), 0.3);
  EXPECT_LT(SecondsSince(start), 10.0);
  EXPECT_THAT(stream->Finish(), IsOk());
}

TEST(FrameStream, ACorruptImageIsDroppedAndCountedAndACleanEndIsOk) {
  transient::testing::CorruptingTransient service;  // a fake: see fake_transient.h
  transient::testing::FakeDaemon daemon(&service);
  const Client client = MustConnect(daemon.address());
  std::unique_ptr<FrameStream> stream = client.StreamFrames(Request({v1::RANGE}));
  std::vector<StreamFrame> frames;
  StreamFrame frame;
  while (stream->Next(&frame)) frames.push_back(frame);
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[0].kind, StreamFrame::Kind::kImages);
  EXPECT_EQ(frames[1].kind, StreamFrame::Kind::kCorrupt);
  EXPECT_TRUE(frames[1].images.empty());
  EXPECT_THAT(frames[1].corruption,
              StatusIs(absl::StatusCode::kDataLoss,
                       AllOf(HasSubstr("frame 1"), HasSubstr("image \"range\""),
                             HasSubstr("data holds 7 bytes"))));
  EXPECT_EQ(frames[2].kind, StreamFrame::Kind::kImages);
  EXPECT_EQ(frames[2].images[0].values[0], transient::testing::FakeRange(2, 0));
  EXPECT_EQ(stream->counts().frames, 2);
  EXPECT_EQ(stream->counts().corrupt, 1);
  EXPECT_EQ(stream->last_corruption(), frames[1].corruption);
  EXPECT_THAT(stream->Finish(), IsOk());
}

}  // namespace
}  // namespace transient::client
