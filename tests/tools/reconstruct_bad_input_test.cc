// Every kind of bad input to `transient reconstruct` gets a one-line error that names the
// file, the object and the rule, and leaves no output (and no temporary) file behind.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/match.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "tests/support/unprivileged.h"
#include "tests/formats/test_files.h"
#include "tools/transient/common/exit_status.h"
#include "tools/transient/commands/reconstruct_command.h"

namespace transient::tools {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::Not;
using ::transient::testing::ScratchDirectory;
using ::testing::StartsWith;
using ::transient::testing::StatusIs;


struct BadInputCase {
  std::string name;
  // Prepares the directory (the small valid file is already there as in.h5) and the args.
  std::function<void(const ScratchDirectory&, ReconstructArgs&)> prepare;
  absl::StatusCode code;
  std::vector<std::string> message_parts;              // each must appear in the message
  std::vector<std::string> entries_after = {"in.h5"};  // the directory afterwards
};

std::ostream& operator<<(std::ostream& os, const BadInputCase& c) { return os << c.name; }

// Breaks the input file with `edit(path)`.
std::function<void(const ScratchDirectory&, ReconstructArgs&)> Edit(
    std::function<void(const std::string&)> edit) {
  return [edit](const ScratchDirectory& dir, ReconstructArgs&) { edit(dir.File("in.h5")); };
}

// Replaces both moment datasets by float32 ones of shape `dims`.
std::function<void(const ScratchDirectory&, ReconstructArgs&)> MomentShape(
    std::vector<hsize_t> dims) {
  return Edit([dims](const std::string& path) {
    testing::ReplaceDataset(path, "/moments/real", H5T_IEEE_F32LE, dims);
    testing::ReplaceDataset(path, "/moments/imag", H5T_IEEE_F32LE, dims);
  });
}

std::function<void(const ScratchDirectory&, ReconstructArgs&)> Args(
    std::function<void(ReconstructArgs&)> change) {
  return [change](const ScratchDirectory&, ReconstructArgs& args) { change(args); };
}

using absl::StatusCode;

// The small file is 2 frames, m = 3, 3x4 px: /moments/real is [2, 4, 3, 4].
const BadInputCase kCases[] = {
    {"NonexistentFile",
     [](const ScratchDirectory& dir, ReconstructArgs&) {
       std::filesystem::remove(dir.File("in.h5"));
     },
     StatusCode::kNotFound,
     {"in.h5: no such file"},
     {}},
    {"InputIsADirectory",
     [](const ScratchDirectory& dir, ReconstructArgs& args) {
       std::filesystem::create_directory(dir.File("sub"));
       args.input_path = dir.File("sub");
     },
     StatusCode::kInvalidArgument,
     {"sub: is a directory"},
     {"in.h5", "sub"}},
    {"TextFile",
     Edit([](const std::string& path) { std::ofstream(path) << "range,amplitude\n1,2\n"; }),
     StatusCode::kInvalidArgument,
     {"in.h5: not an HDF5 file"}},
    {"EmptyFile",
     Edit([](const std::string& path) { std::ofstream{path}; }),
     StatusCode::kInvalidArgument,
     {"in.h5: not an HDF5 file"}},
    {"MissingFormat",
     Edit([](const std::string& path) { testing::DeleteAttribute(path, "/", "format"); }),
     StatusCode::kInvalidArgument,
     {"in.h5: /: missing attribute format"}},
    {"FormatIsNotAString",
     Edit([](const std::string& path) { testing::SetDoubleAttribute(path, "/", "format", 1.0); }),
     StatusCode::kInvalidArgument,
     {"in.h5: /: attribute format: expected a string, found float64"}},
    {"UnknownFormatName",
     Edit([](const std::string& path) {
       testing::SetStringAttribute(path, "/", "format", "transient-capture 1");
     }),
     StatusCode::kInvalidArgument,
     {"in.h5: /: attribute format: expected 'transient-moments 1', found 'transient-capture 1'",
      "not a transient-moments file"}},
    {"UnknownMajorVersion",
     Edit([](const std::string& path) {
       testing::SetStringAttribute(path, "/", "format", "transient-moments 2");
     }),
     StatusCode::kInvalidArgument,
     {"in.h5: /: attribute format: expected 'transient-moments 1', found 'transient-moments 2'",
      "unsupported major version 2"}},
    {"FormatWithoutVersion",
     Edit([](const std::string& path) {
       testing::SetStringAttribute(path, "/", "format", "transient-moments");
     }),
     StatusCode::kInvalidArgument,
     {"in.h5: /: attribute format:", "NAME MAJOR[.MINOR]"}},
    {"MissingMomentsGroup",
     Edit([](const std::string& path) { testing::DeleteObject(path, "/moments"); }),
     StatusCode::kInvalidArgument,
     {"in.h5: /moments: missing group"}},
    {"MissingReal",
     Edit([](const std::string& path) { testing::DeleteObject(path, "/moments/real"); }),
     StatusCode::kInvalidArgument,
     {"in.h5: /moments/real: missing dataset"}},
    {"MissingImag",
     Edit([](const std::string& path) { testing::DeleteObject(path, "/moments/imag"); }),
     StatusCode::kInvalidArgument,
     {"in.h5: /moments/imag: missing dataset"}},
    {"RealIsInt32",
     Edit([](const std::string& path) {
       testing::ReplaceDataset(path, "/moments/real", H5T_STD_I32LE, {2, 4, 3, 4});
     }),
     StatusCode::kInvalidArgument,
     {"in.h5: /moments/real: expected float32 or float64, found int32"}},
    {"ImagIsUint16",
     Edit([](const std::string& path) {
       testing::ReplaceDataset(path, "/moments/imag", H5T_STD_U16LE, {2, 4, 3, 4});
     }),
     StatusCode::kInvalidArgument,
     {"in.h5: /moments/imag: expected float32 or float64, found uint16"}},
    {"RealHasThreeDimensions",
     Edit([](const std::string& path) {
       testing::ReplaceDataset(path, "/moments/real", H5T_IEEE_F32LE, {4, 3, 4});
     }),
     StatusCode::kInvalidArgument,
     {"in.h5: /moments/real: expected 4 dimensions [frames, m+1, height, width], found 3"}},
    {"ImagShapeDiffersFromReal",
     Edit([](const std::string& path) {
       testing::ReplaceDataset(path, "/moments/imag", H5T_IEEE_F32LE, {2, 4, 3, 5});
     }),
     StatusCode::kInvalidArgument,
     {"in.h5: /moments/imag: expected the shape of /moments/real [2, 4, 3, 4], found [2, 4, 3, "
      "5]"}},
    {"OrderZero",
     MomentShape({2, 1, 3, 4}),
     StatusCode::kInvalidArgument,
     {"in.h5: /moments/real: expected m+1 = 2..17 moments (m = 1..16)", "found 1"}},
    {"OrderSeventeen",
     MomentShape({2, 18, 3, 4}),
     StatusCode::kInvalidArgument,
     {"in.h5: /moments/real: expected m+1 = 2..17 moments (m = 1..16)", "found 18"}},
    {"NoFrames",
     MomentShape({0, 4, 3, 4}),
     StatusCode::kInvalidArgument,
     {"in.h5: /moments/real: expected at least 1 frame, found 0"}},
    {"EmptyImage",
     MomentShape({2, 4, 0, 4}),
     StatusCode::kInvalidArgument,
     {"in.h5: /moments/real: expected a non-empty image, found height 0 and width 4"}},
    {"MissingBaseFrequency",
     Edit([](const std::string& path) {
       testing::DeleteAttribute(path, "/moments", "base_frequency_hz");
     }),
     StatusCode::kInvalidArgument,
     {"in.h5: /moments: missing attribute base_frequency_hz"}},
    {"NegativeBaseFrequency",
     Edit([](const std::string& path) {
       testing::SetDoubleAttribute(path, "/moments", "base_frequency_hz", -23e6);
     }),
     StatusCode::kInvalidArgument,
     {"in.h5: /moments: attribute base_frequency_hz: expected a finite value > 0, found -2.3e+07"}},
    {"NaNBaseFrequency",
     Edit([](const std::string& path) {
       testing::SetDoubleAttribute(path, "/moments", "base_frequency_hz", kNaN);
     }),
     StatusCode::kInvalidArgument,
     {"in.h5: /moments: attribute base_frequency_hz: expected a finite value > 0, found nan"}},
    {"BaseFrequencyIsAString",
     Edit([](const std::string& path) {
       testing::SetStringAttribute(path, "/moments", "base_frequency_hz", "23 MHz");
     }),
     StatusCode::kInvalidArgument,
     {"in.h5: /moments: attribute base_frequency_hz: expected a number (float64), found string"}},
    {"ValidHasTheWrongShape",
     Edit([](const std::string& path) {
       testing::ReplaceDataset(path, "/moments/valid", H5T_STD_U8LE, {2, 4, 3});
     }),
     StatusCode::kInvalidArgument,
     {"in.h5: /moments/valid: expected shape [frames, height, width] = [2, 3, 4], found [2, 4, "
      "3]"}},
    {"ValidIsFloat32",
     Edit([](const std::string& path) {
       testing::ReplaceDataset(path, "/moments/valid", H5T_IEEE_F32LE, {2, 3, 4});
     }),
     StatusCode::kInvalidArgument,
     {"in.h5: /moments/valid: expected uint8, found float32"}},
    // Options.
    {"TooFewBins",
     Args([](ReconstructArgs& a) { a.bins = 4; }),
     StatusCode::kInvalidArgument,
     {"--bins = 4: expected an integer in 8..65536"}},
    {"TooManyBins",
     Args([](ReconstructArgs& a) { a.bins = 65537; }),
     StatusCode::kInvalidArgument,
     {"--bins = 65537"}},
    {"ZeroBiasEpsilon",
     Args([](ReconstructArgs& a) { a.bias_epsilon = 0.0; }),
     StatusCode::kInvalidArgument,
     {"--bias-epsilon = 0: expected 1e-06 <= E < 1"}},
    {"BiasEpsilonBelowDoublePrecisionLimit",
     Args([](ReconstructArgs& a) { a.bias_epsilon = 1e-9; }),
     StatusCode::kInvalidArgument,
     {"--bias-epsilon = 1e-09: expected 1e-06 <= E < 1"}},
    {"BiasEpsilonOfOne",
     Args([](ReconstructArgs& a) { a.bias_epsilon = 1.0; }),
     StatusCode::kInvalidArgument,
     {"--bias-epsilon = 1: expected 1e-06 <= E < 1"}},
    {"NaNBiasEpsilon",
     Args([](ReconstructArgs& a) { a.bias_epsilon = kNaN; }),
     StatusCode::kInvalidArgument,
     {"--bias-epsilon = nan"}},
    {"NegativeThreshold",
     Args([](ReconstructArgs& a) { a.threshold = -0.1; }),
     StatusCode::kInvalidArgument,
     {"--threshold = -0.1: expected 0 <= T < 1"}},
    {"ThresholdOfOne",
     Args([](ReconstructArgs& a) { a.threshold = 1.0; }),
     StatusCode::kInvalidArgument,
     {"--threshold = 1: expected 0 <= T < 1"}},
    {"BoundsROfOne",
     Args([](ReconstructArgs& a) { a.bounds_r = 1.0; }),
     StatusCode::kInvalidArgument,
     {"--bounds-r = 1: expected 0 < R < 1"}},
    {"BoundsROfZero",
     Args([](ReconstructArgs& a) { a.bounds_r = 0.0; }),
     StatusCode::kInvalidArgument,
     {"--bounds-r = 0: expected 0 < R < 1"}},
    {"FramesBeyondTheFile",
     Args([](ReconstructArgs& a) { a.frames = {.start = 1, .stop = 3}; }),
     StatusCode::kOutOfRange,
     {"in.h5: --frames = '1:3' of 2 frames: stop 3 is outside -2..2"}},
    {"FramesSelectingNothing",
     Args([](ReconstructArgs& a) { a.frames = {.start = 1, .stop = 1}; }),
     StatusCode::kOutOfRange,
     {"in.h5: --frames = '1:1' of 2 frames: selects no frames"}},
    // Output paths.
    {"OutputDirectoryMissing",
     [](const ScratchDirectory& dir, ReconstructArgs& args) {
       args.output_path = dir.File("missing/out.h5");
     },
     StatusCode::kNotFound,
     {"missing/out.h5: directory", "does not exist"}},
    {"OutputIsADirectory",
     [](const ScratchDirectory& dir, ReconstructArgs&) {
       std::filesystem::create_directory(dir.File("out.h5"));
     },
     StatusCode::kInvalidArgument,
     {"out.h5: is a directory"},
     {"in.h5", "out.h5"}},
    {"ImageLargerThanAnHdf5Chunk",
     Edit([](const std::string& path) {
       testing::ReplaceWithUnwrittenDataset(path, "/moments/real", {1, 4, 20000, 20000});
       testing::ReplaceWithUnwrittenDataset(path, "/moments/imag", {1, 4, 20000, 20000});
       testing::DeleteObject(path, "/moments/valid");
     }),
     StatusCode::kInvalidArgument,
     {"/moments/real: expected at most 268435456 pixels per image, found 20000 x 20000"}},
    // The layout is fine, so the temporary output exists when reading frame 0 fails: it must
    // be removed again.
    {"MomentDataInAMissingExternalFile",
     Edit([](const std::string& path) {
       const std::string missing = path + ".missing.raw";
       testing::ReplaceWithExternalDataset(path, "/moments/real", {2, 4, 3, 4}, missing);
       testing::ReplaceWithExternalDataset(path, "/moments/imag", {2, 4, 3, 4}, missing);
     }),
     StatusCode::kDataLoss,
     {"in.h5: /moments/real: cannot read frame 0"}},
    {"OutputIsTheInput",
     [](const ScratchDirectory& dir, ReconstructArgs& args) {
       args.output_path = dir.File("./in.h5");
     },
     StatusCode::kInvalidArgument,
     {"in.h5: is the input file", "refusing to overwrite it"}},
};

class ReconstructBadInput : public ::testing::TestWithParam<BadInputCase> {};

TEST_P(ReconstructBadInput, FailsWithAOneLineMessageAndLeavesNoOutput) {
  const BadInputCase& bad = GetParam();
  ScratchDirectory dir;
  testing::WriteSmallMomentFile(dir.File("in.h5"));
  ReconstructArgs args{.input_path = dir.File("in.h5"), .output_path = dir.File("out.h5")};
  bad.prepare(dir, args);

  const absl::Status status = RunReconstruct(args).status();

  EXPECT_EQ(status.code(), bad.code) << status;
  for (const std::string& part : bad.message_parts) {
    EXPECT_THAT(std::string(status.message()), HasSubstr(part));
  }
  EXPECT_THAT(std::string(status.message()), Not(HasSubstr("\n")));
  EXPECT_EQ(ExitCodeFor(status), kExitBadInput);
  EXPECT_EQ(dir.Entries(), bad.entries_after);
}

INSTANTIATE_TEST_SUITE_P(Cases, ReconstructBadInput, ::testing::ValuesIn(kCases),
                         [](const ::testing::TestParamInfo<BadInputCase>& info) {
                           return info.param.name;
                         });

TEST(ReconstructBadInput, FileErrorsStartWithTheInputPathAsGiven) {
  ScratchDirectory dir;
  testing::WriteSmallMomentFile(dir.File("in.h5"));
  testing::DeleteObject(dir.File("in.h5"), "/moments/imag");
  const ReconstructArgs args{.input_path = dir.File("in.h5"), .output_path = dir.File("out.h5")};
  EXPECT_THAT(RunReconstruct(args).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(StartsWith(dir.File("in.h5") + ": /moments/imag: "),
                             HasSubstr("missing dataset"))));
}

TEST(ReconstructBadInput, FrameLargerThanMemoryIsRefusedBeforeWritingAnything) {
  // 16000 x 16000 px at m = 16: within the format's limits, but reconstructing one frame
  // needs about 200 GiB. The file itself is a few kB: nothing of the data is written.
  ScratchDirectory dir;
  testing::WriteSmallMomentFile(dir.File("in.h5"));
  testing::ReplaceWithUnwrittenDataset(dir.File("in.h5"), "/moments/real", {1, 17, 16000, 16000});
  testing::ReplaceWithUnwrittenDataset(dir.File("in.h5"), "/moments/imag", {1, 17, 16000, 16000});
  testing::DeleteObject(dir.File("in.h5"), "/moments/valid");
  const ReconstructArgs args{.input_path = dir.File("in.h5"), .output_path = dir.File("out.h5")};
  const absl::Status status = RunReconstruct(args).status();
  EXPECT_THAT(status, StatusIs(absl::StatusCode::kResourceExhausted,
                               AllOf(HasSubstr("in.h5: a 16000x16000 frame with m = 16 needs"),
                                     HasSubstr("GiB of memory"))));
  EXPECT_EQ(ExitCodeFor(status), kExitFailure);
  EXPECT_THAT(dir.Entries(), ElementsAre("in.h5"));
}

TEST(ReconstructBadInput, UnreadableFileIsReportedAsSuch) {
  ScratchDirectory dir;
  testing::WriteSmallMomentFile(dir.File("in.h5"));
  std::filesystem::permissions(dir.File("in.h5"), std::filesystem::perms::none);
  const ReconstructArgs args{.input_path = dir.File("in.h5"), .output_path = dir.File("out.h5")};
  // Root reads every file: the check runs as user nobody then.
  ::transient::testing::AllowOthersIn(dir.path().string());
  EXPECT_EQ(::transient::testing::RunUnprivileged([&] {
              const absl::Status status = RunReconstruct(args).status();
              return status.code() == absl::StatusCode::kPermissionDenied &&
                     absl::StrContains(status.message(), "in.h5: cannot be read");
            }),
            "");
  EXPECT_THAT(dir.Entries(), ElementsAre("in.h5"));
}

TEST(ReconstructBadInput, FailedRunKeepsAnExistingOutputUntouched) {
  ScratchDirectory dir;
  testing::WriteSmallMomentFile(dir.File("in.h5"));
  testing::SetStringAttribute(dir.File("in.h5"), "/", "format", "transient-moments 2");
  std::ofstream(dir.File("out.h5")) << "an earlier result";
  const ReconstructArgs args{.input_path = dir.File("in.h5"), .output_path = dir.File("out.h5")};
  EXPECT_FALSE(RunReconstruct(args).ok());
  std::ifstream kept(dir.File("out.h5"));
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(kept), {}), "an earlier result");
  EXPECT_THAT(dir.Entries(), ElementsAre("in.h5", "out.h5"));
}

}  // namespace
}  // namespace transient::tools
