// Hdf5Mutex: one mutex for the whole process, from every thread, under which threads can share
// HDF5 (Debian's build is not thread-safe).
#include "transient/formats/hdf5_lock.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "tests/formats/test_captures.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "transient/formats/calibration_file.h"

namespace transient {
namespace {

using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;

TEST(Hdf5Lock, IsOneMutexForEveryThread) {
  absl::Mutex* const here = &Hdf5Mutex();
  EXPECT_EQ(&Hdf5Mutex(), here);
  std::vector<absl::Mutex*> seen(4, nullptr);
  std::vector<std::thread> threads;
  for (int i = 0; i < 4; ++i) threads.emplace_back([&seen, i] { seen[i] = &Hdf5Mutex(); });
  for (std::thread& thread : threads) thread.join();
  for (absl::Mutex* mutex : seen) EXPECT_EQ(mutex, here);
}

TEST(Hdf5Lock, IsFreeUntilTakenAndExcludesOtherThreads) {
  if (!Hdf5Mutex().TryLock()) {
    ADD_FAILURE() << "the HDF5 mutex is held between calls into formats/";
    return;
  }
  bool taken_elsewhere = true;
  std::thread other([&] {
    if (Hdf5Mutex().TryLock()) {
      Hdf5Mutex().Unlock();
      taken_elsewhere = true;
    } else {
      taken_elsewhere = false;
    }
  });
  other.join();
  Hdf5Mutex().Unlock();
  EXPECT_FALSE(taken_elsewhere);
}

TEST(Hdf5Lock, ThreadsHoldingItShareHdf5) {
  constexpr int kThreads = 4, kRounds = 5;
  ScratchDirectory scratch;
  const CalibrationTable table =
      testing::TestCalibration(testing::TestCamera(), testing::TestSchedule());
  std::vector<int> round_trips(kThreads, 0);
  std::vector<absl::Status> failures(kThreads);
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      const std::string path = scratch.File(absl::StrCat("c", t, ".h5"));
      for (int round = 0; round < kRounds; ++round) {
        absl::MutexLock lock(&Hdf5Mutex());
        if (absl::Status written = WriteCalibrationFile(path, table); !written.ok()) {
          failures[t] = written;
          return;
        }
        absl::StatusOr<CalibrationTable> read = ReadCalibrationFile(path);
        if (!read.ok()) {
          failures[t] = read.status();
          return;
        }
        // Bit for bit: invalid factors are NaN.
        if (read->real.size() == table.real.size() &&
            std::memcmp(read->real.data(), table.real.data(), table.real.size() * sizeof(float)) ==
                0 &&
            read->valid == table.valid) {
          ++round_trips[t];
        }
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (int t = 0; t < kThreads; ++t) {
    EXPECT_THAT(failures[t], IsOk()) << "thread " << t;
    EXPECT_EQ(round_trips[t], kRounds) << "thread " << t;
  }
}

}  // namespace
}  // namespace transient
