// Calibration files: round trip, atomic write, refusal of bad tables and bad files.
#include "transient/formats/calibration_file.h"

#include <hdf5.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <utility>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/formats/test_captures.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "transient/formats/atomic_output.h"
#include "transient/formats/h5.h"

namespace transient {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using testing::TestCalibration;
using testing::TestCamera;
using testing::TestSchedule;
using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;

TEST(CalibrationFile, RoundTripsEveryField) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("calibration.h5");
  ScheduleOptions options = TestSchedule().options();
  options.sampling = SamplingScheme::kArccos;
  options.phase_steps = 6;
  options.zeroth = ZerothScheme::kLowFrequencyProxy;
  options.takes = 3;
  absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(options);
  ASSERT_THAT(schedule.status(), IsOk());
  const CalibrationTable table = TestCalibration(TestCamera(), *schedule);
  ASSERT_THAT(WriteCalibrationFile(path, table), IsOk());
  EXPECT_THAT(scratch.Entries(), ElementsAre("calibration.h5"));  // no temporary left

  absl::StatusOr<CalibrationTable> read = ReadCalibrationFile(path);
  ASSERT_THAT(read.status(), IsOk());
  EXPECT_EQ(read->geometry, table.geometry);
  EXPECT_EQ(read->order, table.order);
  EXPECT_EQ(read->base_frequency_hz, table.base_frequency_hz);
  EXPECT_EQ(read->takes_averaged, table.takes_averaged);
  EXPECT_EQ(read->schedule.base_frequency_hz, options.base_frequency_hz);
  EXPECT_EQ(read->schedule.order, options.order);
  EXPECT_EQ(read->schedule.sampling, options.sampling);
  EXPECT_EQ(read->schedule.phase_steps, options.phase_steps);
  EXPECT_EQ(read->schedule.zeroth, options.zeroth);
  EXPECT_EQ(read->schedule.proxy_frequency_hz, options.proxy_frequency_hz);
  EXPECT_EQ(read->schedule.exposure_s, options.exposure_s);
  EXPECT_EQ(read->schedule.takes, options.takes);
  ASSERT_EQ(read->real.size(), table.real.size());
  EXPECT_EQ(std::memcmp(read->real.data(), table.real.data(), table.real.size() * 4), 0);
  EXPECT_EQ(std::memcmp(read->imag.data(), table.imag.data(), table.imag.size() * 4), 0);
  EXPECT_EQ(read->valid, table.valid);

  // Writing again replaces the file whole.
  CalibrationTable second = table;
  second.takes_averaged = 99;
  ASSERT_THAT(WriteCalibrationFile(path, second), IsOk());
  EXPECT_EQ(ReadCalibrationFile(path)->takes_averaged, 99);
}

TEST(CalibrationFile, InconsistentTableWritesNothing) {
  ScratchDirectory scratch;
  CalibrationTable table = TestCalibration(TestCamera(), TestSchedule());
  table.valid.pop_back();
  EXPECT_THAT(WriteCalibrationFile(scratch.File("c.h5"), table),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("c.h5: calibration sizes")));
  table = TestCalibration(TestCamera(), TestSchedule());
  table.order = 3;
  EXPECT_THAT(WriteCalibrationFile(scratch.File("c.h5"), table),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("order")));
  EXPECT_TRUE(scratch.Entries().empty());
}

TEST(CalibrationFile, AFinalNameThatIsADirectoryIsRefusedAndNothingIsLeft) {
  // A rename over a non-empty directory would fail (for root too); the path is refused before
  // anything is written. A commit that fails after writing is atomic_output_test.cc's.
  ScratchDirectory scratch;
  std::filesystem::create_directory(scratch.File("c.h5"));
  std::ofstream(scratch.File("c.h5/keep")) << "x";
  EXPECT_THAT(
      WriteCalibrationFile(scratch.File("c.h5"), TestCalibration(TestCamera(), TestSchedule())),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("c.h5: is a directory")));
  EXPECT_EQ(scratch.Entries(), std::vector<std::string>{"c.h5"});
}

TEST(CalibrationFile, MissingDirectoryIsNotFound) {
  ScratchDirectory scratch;
  EXPECT_THAT(WriteCalibrationFile(scratch.File("no/c.h5"),
                                   TestCalibration(TestCamera(), TestSchedule())),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("no/c.h5")));
}

std::string FileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST(CalibrationFile, NeverReplaceWritesANewFileAndRefusesAnExistingOne) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("c.h5");
  CalibrationTable table = TestCalibration(TestCamera(), TestSchedule());
  ASSERT_THAT(WriteCalibrationFile(path, table, CommitMode::kNeverReplace), IsOk());
  EXPECT_EQ(ReadCalibrationFile(path)->takes_averaged, table.takes_averaged);
  const std::string written = FileBytes(path);

  table.takes_averaged += 1;
  EXPECT_THAT(WriteCalibrationFile(path, table, CommitMode::kNeverReplace),
              StatusIs(absl::StatusCode::kAlreadyExists, HasSubstr("c.h5: exists")));
  EXPECT_EQ(FileBytes(path), written);  // untouched
  EXPECT_THAT(scratch.Entries(), ElementsAre("c.h5"));
  // The default replaces it.
  ASSERT_THAT(WriteCalibrationFile(path, table), IsOk());
  EXPECT_EQ(ReadCalibrationFile(path)->takes_averaged, table.takes_averaged);
  EXPECT_THAT(scratch.Entries(), ElementsAre("c.h5"));
}

TEST(CalibrationFile, IsWrittenThroughAtomicOutput) {
  // The refusals of the calibration writer are AtomicOutput::Prepare's, code and message: the
  // same code decides where the file goes and whether it may replace one.
  ScratchDirectory scratch;
  std::filesystem::create_directory(scratch.File("dir"));
  std::ofstream(scratch.File("taken.h5")) << "x";
  const CalibrationTable table = TestCalibration(TestCamera(), TestSchedule());
  for (const auto& [name, mode] :
       {std::pair{"dir", CommitMode::kReplace}, std::pair{"missing/c.h5", CommitMode::kReplace},
        std::pair{"taken.h5", CommitMode::kNeverReplace}}) {
    SCOPED_TRACE(name);
    const absl::Status expected = AtomicOutput::Prepare(scratch.File(name), mode).status();
    ASSERT_FALSE(expected.ok());
    EXPECT_EQ(WriteCalibrationFile(scratch.File(name), table, mode), expected);
  }
  EXPECT_THAT(scratch.Entries(), ElementsAre("dir", "taken.h5"));
}

TEST(CalibrationFile, RefusesBadFilesByName) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("c.h5");
  struct Case {
    const char* name;
    std::function<void(hid_t)> edit;
    const char* message;
  };
  const std::vector<Case> cases = {
      {"format", [](hid_t f) { ASSERT_TRUE(h5::WriteStringAttribute(f, "format", "transient-capture 1").ok()); },
       "c.h5: /: attribute format: expected 'transient-calibration 1', found 'transient-capture 1'"},
      {"order", [](hid_t f) { ASSERT_TRUE(h5::WriteInt64Attribute(f, "order", 3).ok()); },
       "c.h5: /factors/real: expected shape [order+1, height, width] = [4, 5, 7], found [3, 5, 7]"},
      {"zeroth", [](hid_t f) { ASSERT_TRUE(h5::WriteStringAttribute(f, "zeroth", "guess").ok()); },
       "c.h5: /: attribute zeroth:"},
      {"missing valid", [](hid_t f) { H5Ldelete(f, "/factors/valid", H5P_DEFAULT); },
       "c.h5: /factors/valid: missing dataset"},
      {"frequency", [](hid_t f) { ASSERT_TRUE(h5::WriteDoubleAttribute(f, "base_frequency_hz", -1).ok()); },
       "c.h5: /: attribute base_frequency_hz: expected a finite value > 0, found -1"},
      {"imag type", [](hid_t f) {
         H5Ldelete(f, "/factors/imag", H5P_DEFAULT);
         const hsize_t dims[3] = {3, 5, 7};
         h5::Id space = h5::Dataspace(H5Screate_simple(3, dims, nullptr));
         h5::Id d = h5::Dataset(H5Dcreate2(f, "/factors/imag", H5T_STD_I16LE, space.get(),
                                           H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT)); },
       "c.h5: /factors/imag: expected float32 or float64, found int16"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    std::filesystem::remove(path);
    ASSERT_THAT(WriteCalibrationFile(path, TestCalibration(TestCamera(), TestSchedule())), IsOk());
    {
      h5::Id file = h5::File(H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
      ASSERT_TRUE(file.valid());
      c.edit(file.get());
    }
    EXPECT_THAT(ReadCalibrationFile(path).status(),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(c.message)));
  }
  std::ofstream(scratch.File("text.h5")) << "text";
  EXPECT_THAT(ReadCalibrationFile(scratch.File("text.h5")).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("not an HDF5 file")));
  EXPECT_THAT(ReadCalibrationFile(scratch.File("none.h5")).status(),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("none.h5: no such file")));
}

}  // namespace
}  // namespace transient
