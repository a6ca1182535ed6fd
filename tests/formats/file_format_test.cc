// IdentifyFile tells the four formats apart by their root `format` attribute alone, a capture
// still being written included, and names what is not one of them.
#include "transient/formats/file_format.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <hdf5.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <tuple>
#include <utility>

#include "tests/formats/test_captures.h"
#include "tests/formats/test_files.h"
#include "tests/formats/view_test_files.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "transient/formats/calibration_file.h"
#include "transient/formats/capture_file.h"
#include "transient/formats/h5.h"
#include "transient/formats/moment_file.h"
#include "transient/formats/reconstruction_file.h"

namespace transient {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;

// Writes an empty HDF5 file whose root attribute `format` is `text`.
void WriteTaggedFile(const std::string& path, const std::string& text) {
  h5::SilenceErrorStack();
  h5::Id file = h5::File(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT));
  ASSERT_TRUE(file.valid()) << path;
  ASSERT_THAT(h5::WriteStringAttribute(file.get(), "format", text), IsOk());
}

TEST(FileFormat, NamesAndMajorVersionsAreTheFormatsOwn) {
  EXPECT_EQ(FormatName(FileFormat::kCapture), kCaptureFormatName);
  EXPECT_EQ(FormatMajor(FileFormat::kCapture), kCaptureFormatMajor);
  EXPECT_EQ(FormatName(FileFormat::kCalibration), kCalibrationFormatName);
  EXPECT_EQ(FormatMajor(FileFormat::kCalibration), kCalibrationFormatMajor);
  EXPECT_EQ(FormatName(FileFormat::kMoments), kMomentFormatName);
  EXPECT_EQ(FormatMajor(FileFormat::kMoments), kMomentFormatMajor);
  EXPECT_EQ(FormatName(FileFormat::kReconstruction), kReconstructionFormatName);
  EXPECT_EQ(FormatMajor(FileFormat::kReconstruction), kReconstructionFormatMajor);
}

TEST(FileFormat, IdentifiesAFileOfEachFormatAsItsWriterWroteIt) {
  ScratchDirectory scratch;
  testing::WriteTestCapture(scratch.File("capture.h5"), 3, testing::TestOptions());
  ASSERT_THAT(WriteCalibrationFile(
                  scratch.File("calibration.h5"),
                  testing::TestCalibration(testing::TestCamera(), testing::TestSchedule())),
              IsOk());
  tools::testing::WriteSmallMomentFile(scratch.File("moments.h5"));
  tools::testing::WriteViewReconstruction(scratch.File("reconstruction.h5"));
  for (auto [name, format, text] :
       {std::tuple{"capture.h5", FileFormat::kCapture, "transient-capture 1"},
        std::tuple{"calibration.h5", FileFormat::kCalibration, "transient-calibration 1"},
        std::tuple{"moments.h5", FileFormat::kMoments, "transient-moments 1"},
        std::tuple{"reconstruction.h5", FileFormat::kReconstruction,
                   "transient-reconstruction 1"}}) {
    SCOPED_TRACE(name);
    absl::StatusOr<FileIdentity> identity = IdentifyFile(scratch.File(name));
    ASSERT_THAT(identity.status(), IsOk());
    EXPECT_EQ(identity->text, text);
    ASSERT_TRUE(identity->tag.has_value());
    EXPECT_EQ(identity->tag->name, FormatName(format));
    EXPECT_EQ(identity->named, format);
    for (FileFormat other : kFileFormats) EXPECT_EQ(identity->Is(other), other == format);
  }
}

TEST(FileFormat, AKnownNameOfAnotherVersionIsNamedButNotReadable) {
  ScratchDirectory scratch;
  for (auto [text, parsed] :
       {std::pair{"transient-moments 2", true}, std::pair{"transient-moments 1.7", true},
        std::pair{"transient-moments", false}, std::pair{"transient-moments v1", false}}) {
    SCOPED_TRACE(text);
    const std::string path = scratch.File("f.h5");
    WriteTaggedFile(path, text);
    absl::StatusOr<FileIdentity> identity = IdentifyFile(path);
    ASSERT_THAT(identity.status(), IsOk());
    EXPECT_EQ(identity->named, FileFormat::kMoments);  // the reader says what is wrong
    EXPECT_EQ(identity->tag.has_value(), parsed);
    // Another minor version is read; another major version or a malformed tag is not.
    EXPECT_EQ(identity->Is(FileFormat::kMoments), std::string(text) == "transient-moments 1.7");
  }
}

TEST(FileFormat, AnotherNameIsNoneOfTheFormats) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("f.h5");
  WriteTaggedFile(path, "netcdf 4");
  absl::StatusOr<FileIdentity> identity = IdentifyFile(path);
  ASSERT_THAT(identity.status(), IsOk());
  EXPECT_EQ(identity->text, "netcdf 4");
  EXPECT_FALSE(identity->named.has_value());
  for (FileFormat format : kFileFormats) EXPECT_FALSE(identity->Is(format));
}

TEST(FileFormat, RefusesWhatHasNoFormatTag) {
  ScratchDirectory scratch;
  std::filesystem::create_directory(scratch.File("dir"));
  std::ofstream(scratch.File("text.h5")) << "not HDF5";
  {
    h5::Id file = h5::File(
        H5Fcreate(scratch.File("plain.h5").c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT));
    ASSERT_TRUE(file.valid());
  }
  {
    h5::Id file = h5::File(
        H5Fcreate(scratch.File("number.h5").c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT));
    ASSERT_THAT(h5::WriteDoubleAttribute(file.get(), "format", 1.0), IsOk());
  }
  EXPECT_THAT(IdentifyFile(scratch.File("none.h5")).status(),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("none.h5: no such file")));
  EXPECT_THAT(IdentifyFile(scratch.File("dir"), "an HDF5 capture").status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("dir: is a directory, expected an HDF5 capture")));
  EXPECT_THAT(IdentifyFile(scratch.File("text.h5")).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("text.h5: not an HDF5 file")));
  EXPECT_THAT(IdentifyFile(scratch.File("plain.h5")).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("plain.h5: /: missing attribute format (an HDF5 file, but none "
                                 "of this project's formats)")));
  EXPECT_THAT(IdentifyFile(scratch.File("number.h5")).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("number.h5: /: attribute format: expected a string, found "
                                 "float64")));
}

TEST(FileFormat, IdentifiesACaptureStillBeingWritten) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("live.h5");
  // A recorder in a child process: it appends and flushes a frame, so that the file is in SWMR
  // mode, says so, and keeps the file open until told to stop.
  int ready[2], stop[2];
  ASSERT_EQ(pipe(ready), 0);
  ASSERT_EQ(pipe(stop), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    close(ready[0]);
    close(stop[1]);
    const CameraInfo camera = testing::TestCamera();
    const AcquisitionSchedule schedule = testing::TestSchedule();
    absl::StatusOr<CaptureWriter> writer =
        CaptureWriter::Create(path, camera, schedule, testing::TestOptions());
    if (!writer.ok() || !writer->Append(testing::TestFrame(camera, schedule, 0, false)).ok() ||
        !writer->Flush().ok()) {
      _exit(2);
    }
    const char byte = 1;
    if (write(ready[1], &byte, 1) != 1) _exit(3);
    char ignored = 0;
    while (read(stop[0], &ignored, 1) > 0) {
    }
    _exit(0);  // without closing: the file keeps SWMR's marks, as a killed recording's does
  }
  close(ready[1]);
  close(stop[0]);
  char byte = 0;
  ASSERT_EQ(read(ready[0], &byte, 1), 1) << "the recorder failed";
  absl::StatusOr<FileIdentity> live = IdentifyFile(path);
  close(stop[1]);
  int status = 0;
  waitpid(child, &status, 0);
  close(ready[0]);
  ASSERT_THAT(live.status(), IsOk());
  EXPECT_TRUE(live->Is(FileFormat::kCapture));
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "status " << status;

  // The writer is gone without closing the file: its marks stay, and a plain open refuses it.
  h5::SilenceErrorStack();
  EXPECT_LT(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), 0);
  absl::StatusOr<FileIdentity> killed = IdentifyFile(path);
  ASSERT_THAT(killed.status(), IsOk());
  EXPECT_TRUE(killed->Is(FileFormat::kCapture));
}

}  // namespace
}  // namespace transient
