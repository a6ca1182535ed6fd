// The reconstruction file reader: what the writer wrote comes back, broken layouts are named.
#include "transient/formats/reconstruction_reader.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "tests/formats/test_files.h"
#include "tests/formats/view_test_files.h"

namespace transient::tools {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;

TEST(ReconstructionReader, ReadsBackEveryProductTheWriterWrote) {
  ScratchDirectory dir;
  const std::string path = dir.File("r.h5");
  testing::WriteViewReconstruction(path);
  absl::StatusOr<ReconstructionReader> reader = ReconstructionReader::Open(path);
  ASSERT_THAT(reader.status(), IsOk());
  EXPECT_EQ(reader->frames(), testing::kViewFrames);
  EXPECT_EQ(reader->geometry(), testing::kViewGeometry);
  EXPECT_EQ(reader->order(), testing::kViewOrder);
  EXPECT_EQ(reader->bins(), testing::kViewBins);
  EXPECT_EQ(reader->bounds_r(), 0.5);
  EXPECT_TRUE(reader->available().all());

  TransientFrame frame;
  ASSERT_THAT(reader->ReadFrame(1, reader->available(), &frame), IsOk());
  const int64_t pixels = testing::kViewGeometry.pixel_count();
  ASSERT_EQ(frame.density.size(), static_cast<size_t>(testing::kViewBins * pixels));
  for (int n = 0; n < testing::kViewBins; ++n) {
    for (int64_t p = 0; p < pixels; ++p) {
      ASSERT_EQ(frame.density[n * pixels + p], testing::KnownDensity(1, n, p));
      ASSERT_EQ(frame.cumulative[n * pixels + p], testing::KnownCumulative(1, n, p));
    }
  }
  for (int64_t p = 0; p < pixels; ++p) {
    const float range = testing::KnownRange(1, p);
    ASSERT_TRUE(std::isnan(range) ? std::isnan(frame.range_m[p]) : frame.range_m[p] == range);
    ASSERT_EQ(frame.c0[p], testing::KnownC0(1, p));
  }
  EXPECT_EQ(frame.pisarenko_phase.size(), static_cast<size_t>(testing::kViewOrder * pixels));
  EXPECT_FLOAT_EQ(frame.pisarenko_phase[pixels], 2.0f);  // return 1 of pixel 0
  EXPECT_EQ(frame.flags[0], kFlagBiased);
  EXPECT_EQ(frame.index, 1);
  EXPECT_NEAR(frame.BinTimeOfFlightNs(1), 50.0 / testing::kViewBins, 1e-9);
}

TEST(ReconstructionReader, ReadsOnlyTheProductsAskedFor) {
  ScratchDirectory dir;
  const std::string path = dir.File("r.h5");
  testing::WriteViewReconstruction(path);
  absl::StatusOr<ReconstructionReader> reader = ReconstructionReader::Open(path);
  ASSERT_THAT(reader.status(), IsOk());
  TransientFrame frame;
  ASSERT_THAT(reader->ReadFrame(0, reader->available(), &frame), IsOk());
  ASSERT_THAT(reader->ReadFrame(0, Products({Product::kZerothMoment}), &frame), IsOk());
  EXPECT_EQ(frame.c0.size(), static_cast<size_t>(testing::kViewGeometry.pixel_count()));
  EXPECT_TRUE(frame.density.empty());
  EXPECT_TRUE(frame.flags.empty());
  EXPECT_THAT(reader->ReadFrame(2, Products({Product::kRange}), &frame),
              StatusIs(absl::StatusCode::kOutOfRange, HasSubstr("frame 2 is outside 0..1")));
}

TEST(ReconstructionReader, AMissingProductIsNamedWhenAskedFor) {
  ScratchDirectory dir;
  const std::string path = dir.File("r.h5");
  testing::WriteViewReconstruction(path);
  testing::DeleteObject(path, "/bounds/lower");
  testing::DeleteObject(path, "/bounds/upper");
  absl::StatusOr<ReconstructionReader> reader = ReconstructionReader::Open(path);
  ASSERT_THAT(reader.status(), IsOk());
  TransientFrame frame;
  EXPECT_THAT(reader->ReadFrame(0, Products({Product::kBoundsUpper}), &frame),
              StatusIs(absl::StatusCode::kNotFound,
                       HasSubstr("has no dataset /bounds/upper (method 'both'; transient "
                                 "reconstruct --bounds-r R writes /bounds)")));
}

TEST(ReconstructionReader, BrokenLayoutsAreNamedWithFileObjectAndRule) {
  struct Case {
    const char* name;
    void (*edit)(const std::string& path);
    const char* message;
  };
  const Case cases[] = {
      {"another format",
       [](const std::string& path) {
         testing::SetStringAttribute(path, "/", "format", "transient-moments 1");
       },
       "r.h5: /: attribute format: expected 'transient-reconstruction 1', found "
       "'transient-moments 1'"},
      {"missing density",
       [](const std::string& path) { testing::DeleteObject(path, "/density"); },
       "r.h5: missing dataset /density (float32 [frames, bins, height, width], written for "
       "method 'both')"},
      {"wrong c0 shape",
       [](const std::string& path) {
         testing::ReplaceDataset(path, "/c0", H5T_IEEE_F32LE, {2, 8, 11});
       },
       "r.h5: /c0: expected shape [frames, height, width] = [2, 8, 12], found [2, 8, 11]"},
      {"wrong density bins",
       [](const std::string& path) {
         testing::ReplaceDataset(path, "/density", H5T_IEEE_F32LE, {2, 15, 8, 12});
       },
       "r.h5: /density: expected shape [frames, bins, height, width] = [2, 16, 8, 12], found "
       "[2, 15, 8, 12]"},
      {"integer range",
       [](const std::string& path) {
         testing::ReplaceDataset(path, "/range_m", H5T_STD_I32LE, {2, 8, 12});
       },
       "r.h5: /range_m: expected float32 or float64, found int32"},
      {"no base frequency",
       [](const std::string& path) {
         testing::DeleteAttribute(path, "/", "base_frequency_hz");
       },
       "r.h5: /: missing attribute base_frequency_hz"},
      {"bad method",
       [](const std::string& path) { testing::SetStringAttribute(path, "/", "method", "fft"); },
       "r.h5: /: attribute method: expected 'mese', 'pisarenko' or 'both', found 'fft'"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    ScratchDirectory dir;
    const std::string path = dir.File("r.h5");
    testing::WriteViewReconstruction(path);
    c.edit(path);
    EXPECT_THAT(ReconstructionReader::Open(path).status(),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(c.message)));
  }
}

TEST(ReconstructionReader, NotAFileAndNotHdf5AreRefused) {
  ScratchDirectory dir;
  EXPECT_THAT(ReconstructionReader::Open(dir.File("none.h5")).status(),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("none.h5: no such file")));
  const std::string text = dir.File("text.h5");
  std::FILE* file = std::fopen(text.c_str(), "w");
  ASSERT_NE(file, nullptr);
  std::fputs("not hdf5\n", file);
  std::fclose(file);
  EXPECT_THAT(ReconstructionReader::Open(text).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("not an HDF5 file")));
}

}  // namespace
}  // namespace transient::tools
