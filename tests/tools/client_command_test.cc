// `transient client`: option validation, percentiles, an unreachable daemon, whole runs against
// the real daemon (pipeline and gRPC server in this process, on a loopback port), and a fake
// service only for what the real daemon cannot be made to do. The connection itself is the
// client library's, tested in tests/client.
#include "tools/transient/client/client_command.h"

#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <memory>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "tests/client/fake_transient.h"
#include "tests/service/daemon_fixture.h"
#include "tests/support/network.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "tests/support/subprocess.h"
#include "tests/support/wait.h"
#include "tests/tools/image_readers.h"
#include "tools/transient/common/image_writers.h"
#include "transient/formats/capture_file.h"
#include "transient/drivers/capture_source.h"
#include "transient/service/pipeline.h"
#include "transient/service/server.h"
#include "transient/v1/transient.grpc.pb.h"
#include "transient/v1/transient.pb.h"

namespace transient::tools {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::UnorderedElementsAreArray;
using ::transient::testing::ClosedPort;
using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::SecondsSince;
using ::transient::testing::StatusIs;


ClientArgs GoodArgs(const std::string& dir = "/tmp/out") {
  ClientArgs args;
  args.output_dir = dir;
  return args;
}

TEST(ClientArgs, DefaultsWithAnOutputDirectoryAreValid) {
  EXPECT_THAT(GoodArgs().Validate(), IsOk());
  EXPECT_EQ(GoodArgs().connect, "127.0.0.1:50051");
  EXPECT_EQ(GoodArgs().frames, 30);
  EXPECT_EQ(GoodArgs().bins, 64);
}

TEST(ClientArgs, UnknownProductsAreNamedWithTheValidOnes) {
  ClientArgs args = GoodArgs();
  args.products = {"range", "rnage", "slice"};
  EXPECT_THAT(args.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("'rnage', 'slice'"),
                             HasSubstr("valid: range, depth, amplitude, c0, flags, moment_state, "
                                       "slices, cumulative, direct_indirect"))));
  args.products = {};
  EXPECT_THAT(args.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("--products")));
}

TEST(ClientArgs, ExactlyOneOfFramesAndSecondsIsRequired) {
  ClientArgs args = GoodArgs();
  args.seconds = 2.0;
  EXPECT_THAT(args.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                        HasSubstr("exactly one of --frames N and --seconds S")));
  args.frames = 0;
  EXPECT_THAT(args.Validate(), IsOk());
  args.seconds = 0.0;
  EXPECT_THAT(args.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                        HasSubstr("exactly one of --frames N")));
  args.frames = -3;
  EXPECT_THAT(args.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("--frames = -3")));
  args.frames = 0;
  args.seconds = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT(args.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("--seconds = nan")));
}

TEST(ClientArgs, BadNumbersAreRefusedNamingTheOption) {
  ClientArgs args = GoodArgs();
  args.bins = 0;
  EXPECT_THAT(args.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("--bins = 0: expected 1..1024")));
  args = GoodArgs();
  args.bins = 1025;
  EXPECT_THAT(args.Validate(), StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("--bins")));
  args = GoodArgs();
  args.max_rate_hz = -1.0;
  EXPECT_THAT(args.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("--max-rate = -1")));
  args = GoodArgs();
  args.connect_timeout_s = 0.0;
  EXPECT_THAT(args.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("--connect-timeout = 0")));
  args = GoodArgs();
  args.roi = {.x = 0, .y = 0, .width = 10, .height = 0};
  EXPECT_THAT(args.Validate(), StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("--roi")));
  args = GoodArgs();
  args.connect = "";
  EXPECT_THAT(args.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("--connect")));
  args = GoodArgs();
  args.output_dir = "";
  EXPECT_THAT(args.Validate(), StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("--out")));
}

TEST(ClientArgs, BadMomentDepthOptionsAreRefusedNamingTheOption) {
  ClientArgs args = GoodArgs();
  args.products = {"moment_depth"};
  EXPECT_THAT(args.Validate(), IsOk());
  args.moment_near_m = -1.0;
  args.moment_far_m = 3.0;
  EXPECT_THAT(args.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                        HasSubstr("--moment-near = -1")));
  args.moment_near_m = 3.0;
  EXPECT_THAT(args.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                        HasSubstr("--moment-far = 3: expected a depth above")));
  args = GoodArgs();
  args.moment_sigma_px = -0.5;
  EXPECT_THAT(args.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                        HasSubstr("--moment-sigma = -0.5")));
  args = GoodArgs();
  args.moment_bits = 32;
  EXPECT_THAT(args.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                        HasSubstr("--moment-bits = 32: expected 64 or 128")));
  args = GoodArgs();
  args.virtual_plane_m = kNaNf;
  EXPECT_THAT(args.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                        HasSubstr("--virtual-plane = nan")));
}

TEST(ClientArgs, EncodingMustBeKnownAndMillimetresOnlyForLengths) {
  ClientArgs args = GoodArgs();
  args.encoding = "float64";
  EXPECT_THAT(args.Validate(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("--encoding 'float64': expected float32, float16 or mm")));
  args.encoding = "mm";
  args.products = {"range", "depth", "flags"};
  EXPECT_THAT(args.Validate(), IsOk());
  args.products = {"range", "slices"};
  EXPECT_THAT(args.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                        AllOf(HasSubstr("--encoding mm"), HasSubstr("slices"))));
  args.encoding = "float16";
  EXPECT_THAT(args.Validate(), IsOk());
}

TEST(ParseRoi, ReadsFourNonNegativeIntegers) {
  absl::StatusOr<ClientRoi> roi = ParseRoi("1,2,30,40");
  ASSERT_THAT(roi.status(), IsOk());
  EXPECT_EQ(roi->x, 1);
  EXPECT_EQ(roi->y, 2);
  EXPECT_EQ(roi->width, 30);
  EXPECT_EQ(roi->height, 40);
  for (const char* bad : {"1,2,3", "1,2,3,4,5", "a,b,c,d", "-1,0,4,4", "", "1,,3,4"}) {
    EXPECT_THAT(ParseRoi(bad).status(),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("X,Y,W,H")))
        << bad;
  }
}

TEST(RunClient, InterruptWhileConnectingIsCancelled) {
  ScratchDirectory dir;
  ClientArgs args = GoodArgs(dir.File("out"));
  args.connect = absl::StrCat("127.0.0.1:", ClosedPort());
  args.connect_timeout_s = 30.0;
  std::atomic<bool> cancel{true};
  const auto start = std::chrono::steady_clock::now();
  EXPECT_THAT(RunClient(args, {.cancel = &cancel}).status(),
              StatusIs(absl::StatusCode::kCancelled, HasSubstr("connecting")));
  // Well before the 30 s connect timeout (generous for a loaded CI machine).
  EXPECT_LT(SecondsSince(start), 10.0);
}

TEST(RunClient, OutputPathThatIsAFileIsRefusedBeforeConnecting) {
  ScratchDirectory dir;
  std::ofstream(dir.File("file")) << "x";
  ClientArgs args = GoodArgs(dir.File("file"));
  args.connect = absl::StrCat("127.0.0.1:", ClosedPort());
  EXPECT_THAT(RunClient(args).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(dir.File("file"))));
}

// ---- Against the real daemon ----

constexpr int kSimWidth = 32;
constexpr int kSimHeight = 24;

using ::transient::service::testing::Daemon;
using ::transient::service::testing::kSmallSim;

std::string Slurp(const std::string& path) {
  std::ifstream stream(path);
  return std::string(std::istreambuf_iterator<char>(stream), {});
}

std::vector<float> ReadTiffValues(const std::string& path) {
  return testing::ReadTiff(path).values;
}

// The 16-bit samples of a greyscale PNG (stored big-endian).
std::vector<uint16_t> Png16Values(const testing::RawPng& png) {
  std::vector<uint16_t> values(png.bytes.size() / 2);
  for (size_t i = 0; i < values.size(); ++i) {
    values[i] = static_cast<uint16_t>(png.bytes[2 * i] << 8 | png.bytes[2 * i + 1]);
  }
  return values;
}

// True when `value` survived a trip through IEEE half precision: a normal half has 10 mantissa
// bits, so the low 13 of the float's 23 are zero (for 0.5..7 m every half is normal).
bool IsHalfPrecision(float value) { return (std::bit_cast<uint32_t>(value) & 0x1fffu) == 0; }

// `transient client --token-file` (docs/security.md): the token reaches the daemon with every
// call; without it the daemon's UNAUTHENTICATED comes back, as any refusal does.
TEST(RunClient, SendsTheTokenOfItsTokenFile) {
  ScratchDirectory dir;
  const std::string token = dir.File("token");
  std::ofstream(token) << "fedcba9876543210fedcba9876543210\n";
  std::filesystem::permissions(token, std::filesystem::perms::owner_read |
                                          std::filesystem::perms::owner_write);
  absl::StatusOr<service::Access> access =
      service::Access::Load({.token_file = token}, "127.0.0.1:0");
  ASSERT_THAT(access.status(), IsOk());
  Daemon daemon(service::PipelineOptions{.source_uri = kSmallSim}, /*start=*/true,
                std::make_shared<const service::Access>(*std::move(access)));
  ClientArgs args = GoodArgs(dir.File("out"));
  args.connect = daemon.address();
  args.frames = 1;
  EXPECT_THAT(RunClient(args).status(),
              StatusIs(absl::StatusCode::kUnauthenticated, HasSubstr("bearer token")));
  args.security.token_file = token;
  EXPECT_THAT(RunClient(args).status(), IsOk());
}

TEST(RunClient, ReceivesTheAskedFramesAndWritesTheLastOne) {
  Daemon daemon(kSmallSim);
  ScratchDirectory dir;
  ClientArgs args = GoodArgs(dir.File("out"));
  args.connect = daemon.address();
  args.products = {"range", "depth", "slices", "flags"};
  args.frames = 3;
  args.bins = 16;
  args.roi = {.x = 0, .y = 0, .width = kSimWidth, .height = kSimHeight};
  args.zstd = true;
  args.encoding = "float16";
  int64_t progress_calls = 0;
  const absl::StatusOr<ClientSummary> summary =
      RunClient(args, {.on_progress = [&](int64_t done, int64_t total) {
                         ++progress_calls;
                         EXPECT_EQ(total, 3);
                         EXPECT_LE(done, 3);
                       }});
  ASSERT_THAT(summary.status(), IsOk());

  EXPECT_EQ(summary->frames, 3);
  EXPECT_EQ(summary->corrupt_frames, 0);
  EXPECT_EQ(progress_calls, 3);
  // A simulator never fails: the daemon announces no state change.
  EXPECT_EQ(summary->state_announcements, 0);
  EXPECT_TRUE(summary->state_changes.empty());
  EXPECT_EQ(summary->source_uri, kSmallSim);
  EXPECT_EQ(summary->version, "test");
  EXPECT_EQ(summary->camera_width, kSimWidth);
  EXPECT_EQ(summary->camera_height, kSimHeight);
  EXPECT_FALSE(summary->interrupted);
  // Latency: the daemon's reconstruction time plus the loopback, never seconds.
  EXPECT_GT(summary->latency.p50_ms, 0.0);
  EXPECT_LT(summary->latency.max_ms, 5000.0);
  EXPECT_LE(summary->latency.p50_ms, summary->latency.p90_ms);
  EXPECT_LE(summary->latency.p90_ms, summary->latency.p99_ms);
  EXPECT_LE(summary->latency.p99_ms, summary->latency.max_ms);
  EXPECT_GT(summary->rate_hz, 0.0);
  EXPECT_LT(summary->rate_hz, 100.0);  // a 12.5 frames/s source, give or take the network

  // --bins 16: sixteen slices, one bin of the 23 MHz period apart.
  ASSERT_EQ(summary->slice_time_of_flight_ns.size(), 16u);
  for (int k = 0; k < 16; ++k) {
    EXPECT_NEAR(summary->slice_time_of_flight_ns[k], k / 16.0 / 23e6 * 1e9, 1e-6) << k;
  }
  std::vector<std::string> expected_files = {"range.tiff", "depth.png", "flags.png",
                                             "summary.json"};
  for (int k = 0; k < 16; ++k) {
    expected_files.push_back(absl::StrFormat("slices/slice_%03d.png", k));
  }
  EXPECT_THAT(summary->files, UnorderedElementsAreArray(expected_files));
  EXPECT_EQ(summary->files.back(), "summary.json");
  EXPECT_FALSE(std::filesystem::exists(dir.File("out/slices/slice_016.png")));
  EXPECT_FALSE(std::filesystem::exists(dir.File("out/range_mm.png")));  // depth was asked

  // Range in metres over the whole sensor, as float16 on the wire; pixels without a return NaN.
  const testing::RawTiff range_tiff = testing::ReadTiff(dir.File("out/range.tiff"));
  EXPECT_EQ(range_tiff.width, static_cast<uint32_t>(kSimWidth));
  EXPECT_EQ(range_tiff.height, static_cast<uint32_t>(kSimHeight));
  const std::vector<float>& range = range_tiff.values;
  ASSERT_EQ(range.size(), static_cast<size_t>(kSimWidth * kSimHeight));
  const testing::RawPng depth_png = testing::ReadPng(dir.File("out/depth.png"));
  EXPECT_EQ(depth_png.width, static_cast<uint32_t>(kSimWidth));
  EXPECT_EQ(depth_png.height, static_cast<uint32_t>(kSimHeight));
  ASSERT_EQ(depth_png.bit_depth, 16);
  const std::vector<uint16_t> depth_mm = Png16Values(depth_png);
  ASSERT_EQ(depth_mm.size(), range.size());
  int finite = 0;
  for (size_t p = 0; p < range.size(); ++p) {
    if (!std::isfinite(range[p])) continue;
    ++finite;
    EXPECT_GT(range[p], 0.5f) << p;
    EXPECT_LT(range[p], 7.0f) << p;
    EXPECT_TRUE(IsHalfPrecision(range[p])) << p << ": " << range[p];
    // Z in millimetres never exceeds the radial distance.
    EXPECT_GT(depth_mm[p], 0) << p;
    EXPECT_LE(depth_mm[p], range[p] * 1001.0f + 1.0f) << p;
  }
  EXPECT_GT(finite, kSimWidth * kSimHeight / 2);

  const testing::RawPng flags_png = testing::ReadPng(dir.File("out/flags.png"));
  EXPECT_EQ(flags_png.width, static_cast<uint32_t>(kSimWidth));
  EXPECT_EQ(flags_png.height, static_cast<uint32_t>(kSimHeight));
  const testing::RawPng slice_png = testing::ReadPng(dir.File("out/slices/slice_015.png"));
  EXPECT_EQ(slice_png.width, static_cast<uint32_t>(kSimWidth));
  EXPECT_EQ(slice_png.height, static_cast<uint32_t>(kSimHeight));
  EXPECT_GT(summary->slice_scale, 0.0f);
  EXPECT_TRUE(std::isfinite(summary->slice_scale));

  const std::string json = Slurp(dir.File("out/summary.json"));
  EXPECT_THAT(json, HasSubstr("\"frames\": 3,"));
  EXPECT_THAT(json, HasSubstr("\"address\": \"" + daemon.address() + "\""));
  EXPECT_THAT(json, HasSubstr(absl::StrCat("\"source_uri\": \"", kSmallSim, "\"")));
  EXPECT_THAT(json, HasSubstr("\"camera\": {\"width\": 32, \"height\": 24}"));
  EXPECT_THAT(json, HasSubstr(absl::StrCat("\"frames_missed\": ", summary->frames_missed, ",")));
  EXPECT_THAT(json, HasSubstr("\"state_changes\": [],"));
  // The simulator keeps no counters of its own; the daemon was asked.
  ASSERT_TRUE(summary->source_counters.has_value());
  EXPECT_THAT(*summary->source_counters, ::testing::IsEmpty());
  EXPECT_THAT(json, HasSubstr("\"source_counters\": {},"));
  EXPECT_THAT(json, HasSubstr(absl::StrCat("\"latency_ms\": {\"p50\": ",
                                           absl::StrFormat("%.10g", summary->latency.p50_ms),
                                           ", \"p90\": ")));
  EXPECT_THAT(json, HasSubstr("\"slice_time_of_flight_ns\": [0, 2.717391304, "));
  EXPECT_THAT(json, HasSubstr("\"stream_error\": null"));
}

// A renderer's use of MOMENT_DEPTH: the client receives the map and computes the occlusion of a
// virtual plane. In front of the whole scene the plane is visible everywhere, behind it hidden
// wherever the scene has depth, and through the scene partly hidden; the 8-bit picture says the
// same as the summary.
// A camera's counters (a V4L2 source's, docs/v4l2.md) in summary.json and the text summary; none
// known when GetStats failed.
TEST(ClientSummary, SourceCountersAreAnObjectAndTheNonZeroOnesAreSaid) {
  ClientSummary summary;
  summary.source_counters = {{"buffers", 772}, {"sequences_dropped_error_flag", 1},
                             {"restarts", 0}};
  EXPECT_THAT(ClientSummaryJson(summary),
              HasSubstr("\"source_counters\": {\"buffers\": 772, "
                        "\"sequences_dropped_error_flag\": 1, \"restarts\": 0},"));
  EXPECT_THAT(FormatClientSummary(summary),
              HasSubstr("\nsource: buffers 772, sequences_dropped_error_flag 1"));
  EXPECT_THAT(FormatClientSummary(summary), ::testing::Not(HasSubstr("restarts")));
  summary.source_counters.reset();
  EXPECT_THAT(ClientSummaryJson(summary), HasSubstr("\"source_counters\": null,"));
  EXPECT_THAT(FormatClientSummary(summary), ::testing::Not(HasSubstr("source:")));
}

TEST(RunClient, ReceivesMomentDepthAndComputesTheOcclusionOfAVirtualPlane) {
  Daemon daemon(kSmallSim);
  ScratchDirectory dir;
  struct Case {
    double plane_m;
    double min_share, max_share;
  };
  // The mirrors scene lies between 2.1 and 2.8 m (measured), and ~90% of its pixels have depth.
  for (const Case& c : {Case{0.6, 0.0, 0.001}, Case{2.3, 0.3, 0.95}, Case{6.0, 0.8, 1.0}}) {
    SCOPED_TRACE(absl::StrCat("plane at ", c.plane_m, " m"));
    const std::string out = dir.File(absl::StrCat("plane_", c.plane_m));
    ClientArgs args = GoodArgs(out);
    args.connect = daemon.address();
    args.products = {"moment_depth"};
    args.frames = 1;
    args.moment_near_m = 0.5;
    args.moment_far_m = 6.5;
    args.moment_bits = 128;
    args.moment_sigma_px = 1.0;
    args.virtual_plane_m = c.plane_m;
    const absl::StatusOr<ClientSummary> summary = RunClient(args);
    ASSERT_THAT(summary.status(), IsOk());
    ASSERT_TRUE(summary->moment_depth.has_value());
    const ClientSummary::MomentDepth& m = *summary->moment_depth;
    EXPECT_EQ(m.bits, 128);
    EXPECT_DOUBLE_EQ(m.near_m, 0.5);
    EXPECT_DOUBLE_EQ(m.far_m, 6.5);
    EXPECT_DOUBLE_EQ(m.sigma_px, 1.0);
    EXPECT_DOUBLE_EQ(m.virtual_plane_m, c.plane_m);
    EXPECT_GE(m.occluded_share, c.min_share);
    EXPECT_LE(m.occluded_share, c.max_share);
    EXPECT_THAT(summary->files, ::testing::IsSupersetOf({"moment_depth/b1.tiff", "moment_depth/b4.tiff",
                                                       "moment_depth/occlusion_plane.png"}));
    const testing::RawPng png = testing::ReadPng(out + "/moment_depth/occlusion_plane.png");
    EXPECT_EQ(png.width, static_cast<uint32_t>(kSimWidth));
    EXPECT_EQ(png.height, static_cast<uint32_t>(kSimHeight));
    double mean = 0.0;
    for (uint8_t v : png.bytes) mean += v / 255.0;
    mean /= static_cast<double>(png.bytes.size());
    EXPECT_NEAR(mean, m.occluded_share, 0.5 / 255.0 + 1e-9);
    const std::vector<float> b1 = ReadTiffValues(out + "/moment_depth/b1.tiff");
    ASSERT_EQ(b1.size(), static_cast<size_t>(kSimWidth * kSimHeight));
    for (float v : b1) EXPECT_TRUE(v >= -1.0f && v <= 1.0f) << v;
    EXPECT_THAT(Slurp(out + "/summary.json"), HasSubstr("\"moment_depth\": {\"bits\": 128"));
  }
}

TEST(RunClient, RangeAloneAlsoWritesMillimetres) {
  Daemon daemon(kSmallSim);
  ScratchDirectory dir;
  ClientArgs args = GoodArgs(dir.File("out"));
  args.connect = daemon.address();
  args.products = {"range"};
  args.frames = 1;
  args.roi = {.x = 4, .y = 2, .width = 20, .height = 10};
  const absl::StatusOr<ClientSummary> summary = RunClient(args);
  ASSERT_THAT(summary.status(), IsOk());
  EXPECT_THAT(summary->files, ElementsAre("range.tiff", "range_mm.png", "summary.json"));
  // Both files are the ROI, and the millimetres are the metres of the TIFF, rounded.
  const testing::RawTiff tiff = testing::ReadTiff(dir.File("out/range.tiff"));
  EXPECT_EQ(tiff.width, 20u);
  EXPECT_EQ(tiff.height, 10u);
  const testing::RawPng png = testing::ReadPng(dir.File("out/range_mm.png"));
  EXPECT_EQ(png.width, 20u);
  EXPECT_EQ(png.height, 10u);
  ASSERT_EQ(png.bit_depth, 16);
  const std::vector<uint16_t> millimetres = Png16Values(png);
  ASSERT_EQ(tiff.values.size(), 200u);
  ASSERT_EQ(millimetres.size(), 200u);
  int finite = 0;
  for (size_t p = 0; p < millimetres.size(); ++p) {
    finite += std::isfinite(tiff.values[p]);
    EXPECT_EQ(millimetres[p], MetresToMillimetres(tiff.values[p])) << p;
  }
  EXPECT_GT(finite, 100);
}

// A capture file of `cycles` transient frames of the small simulated camera, for replay.
void WriteShortCapture(const std::string& path, int cycles) {
  absl::StatusOr<std::unique_ptr<CaptureSource>> sim = OpenSource(
      absl::StrCat("sim:mirrors?width=32&height=24&pace=fast&frames=", cycles));
  ASSERT_THAT(sim.status(), IsOk());
  ASSERT_THAT((*sim)->Start(), IsOk());
  RawFrame frame;
  ASSERT_THAT((*sim)->Next(absl::Seconds(5), &frame), IsOk());
  absl::StatusOr<CaptureWriter> writer =
      CaptureWriter::Create(path, (*sim)->camera(), (*sim)->schedule(),
                            {.saturation_level = frame.saturation_level});
  ASSERT_THAT(writer.status(), IsOk());
  do {
    ASSERT_THAT(writer->Append(frame), IsOk());
  } while ((*sim)->Next(absl::Seconds(5), &frame).ok());
  ASSERT_THAT(writer->Close(), IsOk());
}

TEST(RunClient, StreamErrorIsReturnedAfterWritingWhatArrived) {
  // A replay that does not loop: the daemon sends its three frames, announces ENDED and ends
  // the stream with OUT_OF_RANGE. The source starts only once the client is subscribed, so no
  // frame is published before it listens; its queue (4) holds the three frames and the end.
  // Paced like the recording (80 ms a frame), not pace=fast: at pace=fast the pipeline's cycle
  // queue (2) can be full of recorded cycles when the end is announced, and the announcement
  // then drops one of them (Pipeline::Impl::PushCycle), so 2 or 3 frames would arrive.
  ScratchDirectory dir;
  const std::string capture = dir.File("three.h5");
  ASSERT_NO_FATAL_FAILURE(WriteShortCapture(capture, 3));
  Daemon daemon(absl::StrCat("replay:", capture, "?pace=realtime"), /*start=*/false);
  ClientArgs args = GoodArgs(dir.File("out"));
  args.connect = daemon.address();
  args.products = {"range"};
  args.frames = 10;
  absl::StatusOr<ClientSummary> summary = absl::UnknownError("not run");
  std::thread client([&] { summary = RunClient(args); });
  EXPECT_TRUE(daemon.WaitForSubscribers(1));
  daemon.pipeline().Start();
  client.join();

  EXPECT_THAT(summary.status(),
              StatusIs(absl::StatusCode::kOutOfRange,
                       AllOf(HasSubstr(absl::StrCat("stream from transientd at ", args.connect,
                                                    " failed after 3 frames")),
                             HasSubstr("ended after 3 frames to this client"))));
  const testing::RawTiff range = testing::ReadTiff(dir.File("out/range.tiff"));
  EXPECT_EQ(range.width, static_cast<uint32_t>(kSimWidth));
  EXPECT_EQ(range.height, static_cast<uint32_t>(kSimHeight));
  EXPECT_TRUE(std::filesystem::exists(dir.File("out/range_mm.png")));
  const std::string json = Slurp(dir.File("out/summary.json"));
  EXPECT_THAT(json, HasSubstr("\"frames\": 3,"));
  EXPECT_THAT(json, HasSubstr("\"frames_missed\": 0,"));
  EXPECT_THAT(json, HasSubstr("\"state_changes\": [{\"after_frames\": 3, \"state\": "
                              "\"ENDED\"}]"));
  EXPECT_THAT(json, HasSubstr("\"stream_error\": \"the source replay:"));
  EXPECT_THAT(json, HasSubstr("ended after 3 frames to this client\""));
  EXPECT_THAT(json, HasSubstr("\"files\": [\"range.tiff\", \"range_mm.png\", \"summary.json\"]"));
}

TEST(RunClient, InterruptWritesWhatArrivedAndIsCancelled) {
  Daemon daemon(kSmallSim);
  ScratchDirectory dir;
  ClientArgs args = GoodArgs(dir.File("out"));
  args.connect = daemon.address();
  args.products = {"range"};
  args.frames = 1000;
  std::atomic<bool> cancel{false};
  const absl::StatusOr<ClientSummary> summary =
      RunClient(args, {.on_progress =
                           [&](int64_t done, int64_t) {
                             if (done == 2) cancel.store(true);
                           },
                       .cancel = &cancel});
  EXPECT_THAT(summary.status(),
              StatusIs(absl::StatusCode::kCancelled, HasSubstr("interrupted after 2 frames")));
  const testing::RawTiff range = testing::ReadTiff(dir.File("out/range.tiff"));
  EXPECT_EQ(range.width, static_cast<uint32_t>(kSimWidth));
  EXPECT_EQ(range.height, static_cast<uint32_t>(kSimHeight));
  const std::string json = Slurp(dir.File("out/summary.json"));
  EXPECT_THAT(json, HasSubstr("\"frames\": 2,"));
  EXPECT_THAT(json, HasSubstr("\"interrupted\": true"));
  EXPECT_THAT(json, HasSubstr("\"stream_error\": null"));  // our cancel is not the daemon's
}

TEST(RunClient, SecondsModeStopsWhenTheTimeIsUp) {
  Daemon daemon(kSmallSim);  // endless: only the clock stops the client
  ASSERT_TRUE(daemon.WaitForFirstFrame());
  ScratchDirectory dir;
  ClientArgs args = GoodArgs(dir.File("out"));
  args.connect = daemon.address();
  args.products = {"range"};
  args.frames = 0;
  args.seconds = 1.0;
  const auto start = std::chrono::steady_clock::now();
  const absl::StatusOr<ClientSummary> summary = RunClient(args);
  const double elapsed = SecondsSince(start);
  ASSERT_THAT(summary.status(), IsOk());
  EXPECT_GT(summary->frames, 0);
  EXPECT_LE(summary->frames, 30);  // 12.5 frames/s for a second, with room for a slow start
  // Functional bounds, generous for a loaded CI machine: the clock, not the frames, ended it.
  EXPECT_LE(summary->seconds, args.seconds + 1.0);
  EXPECT_GE(elapsed, args.seconds);
  EXPECT_LT(elapsed, 10.0);
  EXPECT_FALSE(summary->interrupted);
  EXPECT_TRUE(summary->stream_error.empty());
}

// ---- Against a fake service, for what the real daemon cannot be made to do ----

using ::transient::testing::CorruptingTransient;
using ::transient::testing::FakeDaemon;
using ::transient::testing::FakeRange;

TEST(RunClient, CorruptFrameIsCountedAndACleanEndIsNotAnError) {
  CorruptingTransient service;  // a fake: see tests/client/fake_transient.h
  FakeDaemon daemon(&service);
  ScratchDirectory dir;
  ClientArgs args = GoodArgs(dir.File("out"));
  args.connect = daemon.address();
  args.products = {"range"};
  args.frames = 10;
  const absl::StatusOr<ClientSummary> summary = RunClient(args);
  ASSERT_THAT(summary.status(), IsOk());
  EXPECT_EQ(summary->frames, 2);
  EXPECT_EQ(summary->corrupt_frames, 1);
  EXPECT_EQ(ReadTiffValues(dir.File("out/range.tiff"))[0], FakeRange(2, 0));
}

TEST(RunClient, ProductTheDaemonDoesNotOfferIsRefused) {
  // A fake service: the real daemon cannot be made to offer less than every product, so only a
  // fake's GetInfo can leave one out.
  class Offering final : public v1::Transient::Service {
    grpc::Status GetInfo(grpc::ServerContext*, const v1::GetInfoRequest*,
                         v1::Info* info) override {
      info->add_products(v1::RANGE);
      info->add_products(v1::DEPTH);
      return grpc::Status::OK;
    }
  } service;
  FakeDaemon daemon(&service);
  ScratchDirectory dir;
  ClientArgs args = GoodArgs(dir.File("out"));
  args.connect = daemon.address();
  args.products = {"range", "slices"};
  EXPECT_THAT(RunClient(args).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(HasSubstr("slices"), HasSubstr("offers range, depth"))));
}

// ---- The built binary ----

// The built binary with `arguments` (split at spaces), standard input from /dev/null.
::transient::testing::ProcessResult RunBinary(const std::string& arguments) {
  std::vector<std::string> argv = {TRANSIENT_BINARY};
  for (absl::string_view argument : absl::StrSplit(arguments, ' ', absl::SkipEmpty())) {
    argv.emplace_back(argument);
  }
  return ::transient::testing::RunProcess(argv);
}

TEST(TransientClientBinary, HelpNamesEveryOptionWithDefaultsAndTheFiles) {
  const auto result = RunBinary("client --help");
  EXPECT_EQ(result.exit_code, 0) << result.err;
  for (const char* text : {"--connect", "127.0.0.1:50051", "--products", "range,slices",
                           "--frames", "30", "--seconds", "--out", "--roi", "--bins", "64",
                           "--encoding", "float32", "--zstd", "--max-rate", "Hz",
                           "--connect-timeout", "depth.png", "range.tiff", "summary.json",
                           "millimetres", "metres", "130"}) {
    EXPECT_THAT(result.out, HasSubstr(text));
  }
}

TEST(TransientClientBinary, BadProductExitsWithTwoAndOneErrorLine) {
  ScratchDirectory dir;
  const auto result =
      RunBinary(absl::StrCat("client --products range,bogus --out ", dir.File("out")));
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_EQ(result.err,
            "error: --products: unknown product 'bogus'; valid: range, depth, amplitude, c0, "
            "flags, moment_state, slices, cumulative, direct_indirect, moment_depth, confidence\n");
  EXPECT_EQ(result.out, "");
}

TEST(TransientClientBinary, UnreachableDaemonExitsWithOne) {
  ScratchDirectory dir;
  const std::string address = absl::StrCat("127.0.0.1:", ClosedPort());
  const auto result = RunBinary(
      absl::StrCat("client --connect ", address, " --connect-timeout 0.3 --out ", dir.File("out")));
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_THAT(result.err,
              HasSubstr("error: cannot reach transientd at " + address + " within 0.3 s"));
}

TEST(TransientClientBinary, SecondsAloneReplacesTheDefaultFrames) {
  ScratchDirectory dir;
  const auto result = RunBinary(absl::StrCat("client --seconds 0.2 --connect 127.0.0.1:",
                                              ClosedPort(), " --connect-timeout 0.3 --out ",
                                              dir.File("out")));
  EXPECT_EQ(result.exit_code, 1) << result.err;  // past validation, to the connection
  EXPECT_THAT(result.err, Not(HasSubstr("exactly one of")));
  EXPECT_THAT(result.err, HasSubstr("cannot reach transientd"));
}

}  // namespace
}  // namespace transient::tools
