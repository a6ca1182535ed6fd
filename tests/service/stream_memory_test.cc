// Many subscribers of one transientd, one of them stuck: the others keep the full rate, the
// stuck one loses frames, and the daemon's memory stays bounded; and the heap keeps a freed
// frame's memory for the next frame (in Release only). Built twice: under the
// sanitizers, where the memory is the heap's live bytes (AddressSanitizer's quarantine keeps
// freed memory resident on purpose), and in Release (ctest label `release`), where it is the
// process's resident pages.
#include <grpcpp/grpcpp.h>
#include <sys/resource.h>

#include <atomic>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/time/clock.h"
#include "gtest/gtest.h"
#include "tests/service/daemon_fixture.h"
#include "transient/v1/transient.grpc.pb.h"
#include "transient/wire/frame_memory.h"

#ifdef TRANSIENT_ADDRESS_SANITIZER
#include <sanitizer/allocator_interface.h>
#endif

namespace transient::service {
namespace {

using ::transient::service::testing::Daemon;
using ::transient::service::testing::kSmallSim;
using ::transient::service::testing::Request;

#ifdef TRANSIENT_ADDRESS_SANITIZER
constexpr char kMemoryMeasure[] = "live heap (AddressSanitizer's count)";
int64_t MemoryInUse() { return static_cast<int64_t>(__sanitizer_get_current_allocated_bytes()); }
#else
constexpr char kMemoryMeasure[] = "resident memory";
// Resident memory of this process (daemon and clients), bytes.
int64_t MemoryInUse() {
  std::ifstream status("/proc/self/status");
  std::string key;
  while (status >> key) {
    if (key == "VmRSS:") {
      int64_t kib = 0;
      status >> kib;
      return kib * 1024;
    }
    status.ignore(1 << 20, '\n');
  }
  return -1;
}
#endif

TEST(StreamMemory, TwentySubscribersOneNeverReadsTheOthersKeepTheFullRate) {
  Daemon daemon(kSmallSim);
  // The stuck client asks for big frames (64 slices) with a 2-frame queue and never reads.
  grpc::ClientContext stuck_context;
  auto stuck_stub = daemon.Stub();
  v1::StreamRequest stuck_request = Request({v1::SLICES, v1::MOMENT_STATE});
  stuck_request.set_queue_frames(2);
  std::unique_ptr<grpc::ClientReader<v1::Frame>> stuck =
      stuck_stub->StreamFrames(&stuck_context, stuck_request);

  constexpr int kReaders = 19;
  std::atomic<bool> stop{false};
  std::vector<int> counts(kReaders, 0);
  std::vector<uint64_t> missed(kReaders, 0);
  std::vector<std::thread> readers;
  std::vector<std::unique_ptr<grpc::ClientContext>> contexts;
  std::atomic<int> started{0};
  for (int i = 0; i < kReaders; ++i) {
    contexts.push_back(std::make_unique<grpc::ClientContext>());
    readers.emplace_back([&, i] {
      auto stub = daemon.Stub();
      auto reader = stub->StreamFrames(contexts[i].get(), Request({v1::RANGE, v1::AMPLITUDE}));
      v1::Frame frame;
      bool first = true;
      while (!stop && reader->Read(&frame)) {
        if (frame.images_size() == 0) continue;
        if (first) {
          ++started;
          first = false;
          continue;  // counting starts once every reader is in
        }
        if (started.load() == kReaders) {
          ++counts[i];
          missed[i] += frame.missed();
        }
      }
    });
  }
  const absl::Time begin_wait = absl::Now() + absl::Seconds(20);
  while (started.load() < kReaders && absl::Now() < begin_wait) absl::SleepFor(absl::Milliseconds(10));
  ASSERT_EQ(started.load(), kReaders);
  // Two seconds for the stuck stream to fill its queue and gRPC's flow-control window; from
  // then on its frames must be dropped, not kept.
  absl::SleepFor(absl::Seconds(2));
  const uint64_t published_before = daemon.Stats().frames_published();
  const int64_t memory_before = MemoryInUse();
  absl::SleepFor(absl::Seconds(3));
  const v1::Stats stats = daemon.Stats();
  const int64_t memory_after = MemoryInUse();
  const uint64_t published = stats.frames_published() - published_before;
  stop = true;
  for (auto& c : contexts) c->TryCancel();
  stuck_context.TryCancel();
  for (auto& t : readers) t.join();

  ASSERT_GT(published, 10u) << "the simulated camera runs at ~12 frames/s";
  for (int i = 0; i < kReaders; ++i) {
    // Every reader got (nearly) every frame published meanwhile; none was dropped for it.
    EXPECT_GE(counts[i], static_cast<int>(published) - 3) << "reader " << i;
    EXPECT_EQ(missed[i], 0u) << "reader " << i;
  }
  // The stuck subscriber lost frames instead of holding them all.
  uint64_t stuck_missed = 0;
  int subscribers = 0;
  for (const v1::SubscriberStats& s : stats.subscribers()) {
    ++subscribers;
    if (s.products_size() == 2 && s.products(1) == v1::SLICES) stuck_missed = s.frames_missed();
  }
  EXPECT_EQ(subscribers, kReaders + 1);
  EXPECT_GT(stuck_missed, 0u);
  // The pipeline keeps up: one that cannot drops most cycles; a busy shared machine can cost
  // a few (a fresh-clone `make test` once dropped 6 in the whole run, against ~36 published in
  // the 3 s measured, and passed on every rerun), so a quarter of those is allowed, not none.
  EXPECT_LE(stats.cycles_dropped(), std::max<uint64_t>(published / 4, 1))
      << "the pipeline fell behind";
  // Bounded memory: the stuck client's ~37 frames of 64 slices (200 kB each, 7.5 MB) of these
  // 3 seconds are not kept.
  EXPECT_LT(memory_after - memory_before, int64_t{4} << 20)
      << kMemoryMeasure << " grew from " << memory_before << " to " << memory_after << " bytes";
}

#ifndef TRANSIENT_ADDRESS_SANITIZER
// Minor page faults this thread has taken.
int64_t MinorFaults() {
  rusage usage{};
  getrusage(RUSAGE_THREAD, &usage);
  return usage.ru_minflt;
}

// A frame's planes, allocated and written, then freed: 64 slices at 640x480, one 1.2 MB block
// a plane as the encoder allocates them (78 MB, 19,200 pages).
void OneFrame() {
  constexpr size_t kPlaneBytes = 640 * 480 * sizeof(float);
  std::vector<std::unique_ptr<char[]>> planes;
  for (int i = 0; i < 64; ++i) {
    planes.push_back(std::make_unique_for_overwrite<char[]>(kPlaneBytes));
    std::memset(planes.back().get(), i, kPlaneBytes);
    asm volatile("" : : "r"(planes.back().get()) : "memory");  // the writes stay
  }
}

// In its own process (a suite is one): the setting is the process's. Not under the
// sanitizers, whose allocator is their own (KeepFreedFrameMemory does nothing there). Without
// the call the second frame took 19,200 faults, one a page: glibc had trimmed the heap.
TEST(FrameMemory, TheNextFrameReusesAFreedFramesPagesWithoutFaults) {
  ASSERT_TRUE(wire::KeepFreedFrameMemory().ok());
  OneFrame();  // the first frame faults its pages in
  const int64_t before = MinorFaults();
  OneFrame();
  EXPECT_LT(MinorFaults() - before, 1000) << "minor page faults of the second frame";
}
#endif

}  // namespace
}  // namespace transient::service
