// The built `transient` executable, run as a subprocess: exit codes, one-line errors on
// stderr, the summary on stdout.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/subprocess.h"
#include "tests/formats/test_files.h"

namespace transient::tools {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::MatchesRegex;
using ::transient::testing::ScratchDirectory;
using ::testing::SizeIs;
using ::testing::StartsWith;

using Result = ::transient::testing::ProcessResult;

std::vector<std::string> Lines(const std::string& text) {
  return absl::StrSplit(text, '\n', absl::SkipEmpty());
}

// Runs TRANSIENT_BINARY with `args` (tests/support/subprocess.h).
Result Run(const std::vector<std::string>& args) {
  std::vector<std::string> argv = {TRANSIENT_BINARY};
  argv.insert(argv.end(), args.begin(), args.end());
  return ::transient::testing::RunProcess(argv);
}

class TransientBinary : public ::testing::Test {
 protected:
  void SetUp() override { testing::WriteSmallMomentFile(input()); }
  std::string input() const { return dir_.File("in.h5"); }
  std::string output() const { return dir_.File("out.h5"); }
  Result Run(const std::vector<std::string>& args) const { return tools::Run(args); }

  ScratchDirectory dir_;
};

TEST_F(TransientBinary, GoodFileExitsWithZeroAndPrintsOneSummaryLine) {
  const Result result = Run({"reconstruct", input(), output()});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_THAT(result.err, IsEmpty());  // stderr is not a terminal: no progress bar
  EXPECT_THAT(Lines(result.out), ElementsAre(HasSubstr("2 frames of 4x3 px (24 pixels), m=3")));
  EXPECT_THAT(result.out, HasSubstr("-> " + output()));
  EXPECT_THAT(dir_.Entries(), ElementsAre("in.h5", "out.h5"));
}

TEST_F(TransientBinary, SourcesListsEverySchemeWithItsKeys) {
  const Result result = Run({"sources"});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  for (const char* text : {"sim:<scene>?key=value", "replay:<capture.h5>", "calibration scene",
                           "m (default 3)", "pace (default realtime)", "width (default 163 px)"}) {
    EXPECT_THAT(result.out, HasSubstr(text));
  }
}

TEST_F(TransientBinary, DevicesListsWhatThisMachineHasAndExitsZero) {
  // This machine has no V4L2 nodes (tests/drivers/v4l2 lists emulated ones); one with cameras
  // lists them with their URIs. (OpenNI2's devices: tests/openni2, with its own runtime.)
  const Result result = Run({"devices", "--no-openni2"});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.err, "");
  if (std::filesystem::exists("/dev/video0")) {
    EXPECT_THAT(result.out, HasSubstr("v4l2:/dev/video"));
  } else {
    EXPECT_EQ(result.out, "no capture devices found (looked for V4L2 nodes /dev/videoN and Kinect v2 "
            "cameras on USB)\n");
  }
}

TEST_F(TransientBinary, BadFileExitsWithTwoAndOneErrorLine) {
  testing::SetStringAttribute(input(), "/", "format", "transient-moments 2");
  const Result result = Run({"reconstruct", input(), output()});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_THAT(Lines(result.err),
              ElementsAre(StartsWith("error: " + input() +
                                     ": /: attribute format: expected 'transient-moments 1'")));
  EXPECT_THAT(result.out, IsEmpty());
  EXPECT_THAT(dir_.Entries(), ElementsAre("in.h5"));
}

TEST_F(TransientBinary, WrongShapeNamesTheDatasetAndTheExpectedShape) {
  testing::ReplaceDataset(input(), "/moments/real", H5T_IEEE_F32LE, {2, 4, 3});
  const Result result = Run({"reconstruct", input(), output()});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_THAT(Lines(result.err),
              ElementsAre("error: " + input() +
                          ": /moments/real: expected 4 dimensions [frames, m+1, height, width], "
                          "found 3"));
  EXPECT_THAT(dir_.Entries(), ElementsAre("in.h5"));
}

TEST_F(TransientBinary, NonexistentFileExitsWithTwo) {
  const Result result = Run({"reconstruct", dir_.File("nothing.h5"), output()});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_THAT(Lines(result.err), ElementsAre(HasSubstr("nothing.h5: no such file")));
}

TEST_F(TransientBinary, OutOfRangeOptionExitsWithTwo) {
  const Result result = Run({"reconstruct", input(), output(), "--bins", "4"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_THAT(Lines(result.err), ElementsAre("error: --bins = 4: expected an integer in 8..65536"));
  EXPECT_THAT(dir_.Entries(), ElementsAre("in.h5"));
}

TEST_F(TransientBinary, UnknownMethodExitsWithTwo) {
  const Result result = Run({"reconstruct", input(), output(), "--method", "fast"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_THAT(Lines(result.err),
              ElementsAre("error: --method = 'fast': expected mese, pisarenko or both"));
}

TEST_F(TransientBinary, UnparsableOptionsExitWithTwoAndOneLine) {
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"reconstruct", input(), output(), "--bins", "many"},
           {"reconstruct", input(), output(), "--frames", "1:2:3"},
           {"reconstruct", input()},
           {"reconstruct", input(), output(), "--no-such-option"},
           {"deconstruct", input(), output()},
           {}}) {
    const Result result = Run(args);
    EXPECT_EQ(result.exit_code, 2) << absl::StrJoin(args, " ");
    EXPECT_THAT(Lines(result.err), ElementsAre(StartsWith("error: "))) << absl::StrJoin(args, " ");
  }
  EXPECT_THAT(dir_.Entries(), ElementsAre("in.h5"));
}

TEST_F(TransientBinary, HelpExitsWithZero) {
  const Result result = Run({"reconstruct", "--help"});
  EXPECT_EQ(result.exit_code, 0);
  EXPECT_THAT(result.out, HasSubstr("--bias-epsilon"));
  EXPECT_THAT(result.out, HasSubstr("--frames"));
}

TEST_F(TransientBinary, AllOptionsAreAccepted) {
  const Result result =
      Run({"reconstruct", input(), output(), "--method", "mese", "--bins", "16", "--bias-epsilon",
           "1e-2", "--bias-mode", "scale", "--zeroth", "estimate", "--threshold", "0.2",
           "--bounds-r", "0.7", "--frames", "1:"});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_THAT(Lines(result.out), ElementsAre(MatchesRegex("1 frame of 4x3 px .* mese: .*")));
}


// The measurement commands: the sequence of docs/measuring.md runs, and every bad input gets one error line
// and exit code 2 with nothing written.
TEST_F(TransientBinary, MeasurementSequenceRunsAndInfoDescribesEachFile) {
  const std::string camera = "width=24&height=18";
  ASSERT_EQ(Run({"sim", "mirrors", "--out", dir_.File("capture.h5"), "--frames", "2", "--set",
                 "width=24", "--set", "height=18"})
                .exit_code,
            0);
  ASSERT_EQ(Run({"calibrate", "--source", "sim:calibration?pace=fast&" + camera, "--takes", "3",
                 "--out", dir_.File("calibration.h5")})
                .exit_code,
            0);
  const Result moments = Run({"moments", dir_.File("capture.h5"), "--calibration",
                              dir_.File("calibration.h5"), "--out", dir_.File("moments.h5")});
  ASSERT_EQ(moments.exit_code, 0) << moments.err;
  EXPECT_THAT(moments.out, HasSubstr("2 transient frames"));
  const Result info = Run({"info", dir_.File("capture.h5")});
  EXPECT_EQ(info.exit_code, 0) << info.err;
  EXPECT_THAT(info.out, HasSubstr("transient-capture 1"));
  EXPECT_THAT(info.out, HasSubstr("28 raw"));
}

TEST_F(TransientBinary, BadMeasurementInputsGiveOneErrorLineAndExitCodeTwo) {
  {
    std::ofstream text(dir_.File("notes.txt"));
    text << "not HDF5\n";
  }
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"sim", "nowhere", "--out", dir_.File("a.h5")},
           {"sim", "mirrors", "--out", dir_.File("a.h5"), "--m", "0"},
           {"sim", "mirrors", "--out", dir_.File("a.h5"), "--set", "colour=blue"},
           {"sim", "mirrors", "--out", dir_.File("a.h5"), "--frames", "0"},
           {"record", "--source", "usb:9", "--out", dir_.File("a.h5"), "--frames", "1"},
           {"record", "--source", "sim:mirrors", "--out", dir_.File("a.h5")},
           {"record", "--source", "replay:" + dir_.File("missing.h5"), "--out", dir_.File("a.h5"),
            "--frames", "1"},
           {"calibrate", "--source", "sim:calibration?m=99", "--out", dir_.File("c.h5")},
           {"moments", input(), "--out", dir_.File("m.h5"), "--uncalibrated"},
           {"moments", dir_.File("notes.txt"), "--out", dir_.File("m.h5"), "--uncalibrated"},
           {"info", dir_.File("notes.txt")},
           {"info", dir_.File("missing.h5")},
       }) {
    const Result result = Run(args);
    EXPECT_EQ(result.exit_code, 2) << absl::StrJoin(args, " ");
    EXPECT_THAT(Lines(result.err), ElementsAre(StartsWith("error: "))) << absl::StrJoin(args, " ");
  }
  EXPECT_THAT(dir_.Entries(), ::testing::UnorderedElementsAre("in.h5", "notes.txt"));
}

}  // namespace
}  // namespace transient::tools
