// The queue between the daemon's threads: a live source's oldest cycle is dropped and counted,
// a source that waits for its consumer waits for room, announcements take no room and stay
// bounded, and Close wakes whoever waits.
#include "cycle_queue.h"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "tests/support/wait.h"

namespace transient::service {
namespace {

using ::transient::testing::WaitUntil;

CycleItem Cycle(int64_t number) {
  CycleItem item;
  item.frames.resize(1);
  item.frames[0].config.cycle = number;
  return item;
}

CycleItem Announcement(SourceState state) {
  CycleItem item;
  item.announcement = true;
  item.state = state;
  return item;
}

TEST(CycleQueue, ALiveSourceDropsTheOldestCycleAndCountsIt) {
  CycleQueue queue(2);
  EXPECT_EQ(queue.Push(Cycle(0)), 0);
  EXPECT_EQ(queue.Push(Cycle(1)), 0);
  EXPECT_EQ(queue.Push(Cycle(2)), 1);
  for (int64_t expected : {1, 2}) {
    std::optional<CycleItem> item = queue.Pop(absl::ZeroDuration());
    ASSERT_TRUE(item.has_value());
    EXPECT_EQ(item->frames[0].config.cycle, expected);
  }
  EXPECT_FALSE(queue.Pop(absl::Milliseconds(1)).has_value());
}

TEST(CycleQueue, AnnouncementsTakeNoRoomKeepTheirOrderAndStayBounded) {
  CycleQueue queue(1);
  queue.Push(Cycle(0));
  for (size_t i = 0; i < CycleQueue::kMaxAnnouncements + 3; ++i) {
    EXPECT_EQ(queue.Push(Announcement(i % 2 ? SourceState::kStreaming
                                            : SourceState::kReconnecting)),
              0);
  }
  EXPECT_EQ(queue.Push(Cycle(1)), 1) << "the older cycle goes, not an announcement";
  size_t announcements = 0, cycles = 0;
  while (std::optional<CycleItem> item = queue.Pop(absl::ZeroDuration())) {
    (item->announcement ? announcements : cycles) += 1;
  }
  EXPECT_EQ(announcements, CycleQueue::kMaxAnnouncements);
  EXPECT_EQ(cycles, 1u);
}

TEST(CycleQueue, ASourceThatWaitsForItsConsumerLosesNothing) {
  CycleQueue queue(1);
  queue.set_wait_for_room(true);
  std::atomic<int> pushed{0};
  std::thread producer([&] {
    for (int64_t c = 0; c < 5; ++c) {
      EXPECT_EQ(queue.Push(Cycle(c)), 0);
      ++pushed;
    }
  });
  for (int64_t expected = 0; expected < 5; ++expected) {
    std::optional<CycleItem> item = queue.Pop(absl::Seconds(10));
    ASSERT_TRUE(item.has_value());
    EXPECT_EQ(item->frames[0].config.cycle, expected);
  }
  producer.join();
  EXPECT_EQ(pushed.load(), 5);
}

TEST(CycleQueue, CloseWakesAWaitingProducerAndEndsPops) {
  CycleQueue queue(1);
  queue.set_wait_for_room(true);
  queue.Push(Cycle(0));
  std::atomic<bool> returned{false};
  std::thread producer([&] {
    queue.Push(Cycle(1));  // waits: no room
    returned = true;
  });
  absl::SleepFor(absl::Milliseconds(20));
  EXPECT_FALSE(returned.load());
  queue.Close();
  EXPECT_TRUE(WaitUntil([&] { return returned.load(); }));
  producer.join();
  EXPECT_FALSE(queue.Pop(absl::ZeroDuration()).has_value());
  EXPECT_EQ(queue.Push(Cycle(2)), 0);
  EXPECT_FALSE(queue.Pop(absl::ZeroDuration()).has_value());
}

}  // namespace
}  // namespace transient::service
