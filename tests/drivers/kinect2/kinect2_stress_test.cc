// usb:kinect2 streaming from the emulated Kinect v2 at the camera's rate (30 frames/s) with
// random stream faults: no frame lost without a count, every delivered frame right, and no
// growth of memory or file descriptors. `make test` runs it for TRANSIENT_KINECT2_STRESS_SECONDS
// (1.5 by default: under the sanitizers the emulated camera runs at a third of its rate); the
// issue's ten minutes: TRANSIENT_KINECT2_STRESS_SECONDS=600 (docs/kinect2.md
// has the measured run).
#include <dirent.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <random>
#include <span>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "tests/drivers/kinect2/emulated_kinect2.h"
#include "tests/support/status_matchers.h"
#include "transient/drivers/capture_source.h"

namespace transient::kinect2 {
namespace {

using ::transient::testing::IsOk;
namespace emu = ::transient::kinect2::testing;

// On the companding grid, see the source test.
float StressSample(uint32_t n, int s, int x, int y) {
  return static_cast<float>(64 * (((static_cast<int>(n % 7) * 10 + s) * 2 + (x + y) % 2) - 70));
}

int64_t ResidentBytes() {
  std::ifstream statm("/proc/self/statm");
  int64_t size = 0, resident = 0;
  statm >> size >> resident;
  return resident * sysconf(_SC_PAGESIZE);
}

int OpenFds() {
  int count = 0;
  if (DIR* dir = opendir("/proc/self/fd")) {
    while (readdir(dir) != nullptr) ++count;
    closedir(dir);
  }
  return count;
}

TEST(Kinect2Stress, StreamsAtTheCameraRateWithRandomFaultsCountingEveryLoss) {
  ASSERT_TRUE(emu::EmulatedKinect2::Available());
  const char* env = std::getenv("TRANSIENT_KINECT2_STRESS_SECONDS");
  const double seconds = env != nullptr ? std::atof(env) : 1.5;
  const int64_t frames = static_cast<int64_t>(seconds * 30.0);
  ASSERT_GE(frames, 45);

  // At most one fault per frame, in one frame of 15, never in the first two or the last two.
  std::mt19937 rng(2026);
  emu::Options options;
  options.realtime = true;
  options.max_frames = frames;
  options.renderer = [](uint32_t n, int s, std::span<float> v) {
    for (int y = 0; y < 424; ++y) {
      for (int x = 0; x < 512; ++x) v[y * 512 + x] = StressSample(n, s, x, y);
    }
  };
  int64_t expected_incomplete = 0;
  const emu::Fault::Kind kinds[] = {emu::Fault::kPacketError, emu::Fault::kShortPacket,
                                    emu::Fault::kZeroLengthPacket, emu::Fault::kLostSubPacket,
                                    emu::Fault::kWrongFooterLength};
  for (int64_t n = 2; n + 2 < frames; ++n) {
    if (rng() % 15 != 0) continue;
    const emu::Fault::Kind kind = kinds[rng() % 5];
    const int subframe = static_cast<int>(rng() % 10);
    const int packet = 1 + static_cast<int>(rng() % 8);
    const uint32_t sequence = static_cast<uint32_t>(n);
    options.faults.push_back(kind == emu::Fault::kLostSubPacket ||
                                     kind == emu::Fault::kWrongFooterLength
                                 ? emu::Fault::AtSubFrame(kind, sequence, subframe, 7)
                                 : emu::Fault::AtPacket(kind, sequence, subframe, packet));
    expected_incomplete += subframe < 9;  // sub-frame 9 is not needed for a frame
  }
  absl::StatusOr<std::unique_ptr<emu::EmulatedKinect2>> camera =
      emu::EmulatedKinect2::Create(std::move(options));
  ASSERT_THAT(camera.status(), IsOk());

  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSource("usb:kinect2");
  ASSERT_THAT(source.status(), IsOk());
  ASSERT_THAT((*source)->Start(), IsOk());
  RawFrame frame;
  int64_t delivered = 0, wrong = 0, rss_after_warmup = 0;
  int fds_after_warmup = 0;
  while (true) {
    const absl::Status status = (*source)->Next(absl::Seconds(3), &frame);
    if (absl::IsDeadlineExceeded(status)) break;  // the camera sent its last frame
    ASSERT_THAT(status, IsOk());
    const int k = static_cast<int>(frame.config.sequence % 10);
    const uint32_t n = static_cast<uint32_t>(frame.config.cycle);  // the stream starts at 0
    wrong += frame.pixels[211 * 512 + 300] != StressSample(n, k, 300, 211);
    if (k == 8 && ++delivered == 30) {
      rss_after_warmup = ResidentBytes();
      fds_after_warmup = OpenFds();
    }
  }
  std::map<std::string, int64_t> counters;
  for (const SourceCounter& c : (*source)->Counters()) counters[c.name] = c.value;
  ASSERT_THAT((*source)->Stop(), IsOk());
  const int64_t rss_growth = ResidentBytes() - rss_after_warmup;
  std::printf("%lld frames in %.0f s: %lld delivered, %lld incomplete, %lld dropped by the "
              "queue, %lld iso packets (%lld failed); RSS %+.1f MB after warm-up, fds %d -> %d\n",
              static_cast<long long>(frames), seconds, static_cast<long long>(delivered),
              static_cast<long long>(counters["frames_incomplete"]),
              static_cast<long long>(counters["frames_dropped_queue"]),
              static_cast<long long>(counters["iso_packets"]),
              static_cast<long long>(counters["iso_packet_errors"]), rss_growth / 1e6,
              fds_after_warmup, OpenFds());
  EXPECT_EQ(wrong, 0);
  // Every frame the camera sent is delivered, or counted as incomplete or dropped.
  EXPECT_EQ(counters["frames"] + counters["frames_incomplete"], frames);
  EXPECT_EQ(counters["frames_incomplete"], expected_incomplete);
  EXPECT_EQ(delivered + counters["frames_dropped_queue"], counters["frames"]);
  EXPECT_LT(rss_growth, 32'000'000);
  EXPECT_EQ(OpenFds(), fds_after_warmup);
  RecordProperty("frames", absl::StrCat(frames));
  RecordProperty("rss_growth_bytes", absl::StrCat(rss_growth));
}

}  // namespace
}  // namespace transient::kinect2
