// MomentFileWriter writes what MomentFile reads back: every plane, the valid and flags planes,
// the timestamps and the zeroth-moment hint.
#include "transient/formats/moment_file_writer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <random>

#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "transient/formats/moment_file.h"

namespace transient::tools {
namespace {

using ::testing::ElementsAreArray;
using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;

MomentImage RandomImage(ImageGeometry geometry, int order, uint64_t seed) {
  MomentImage image(geometry, order);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> value(-3.0f, 3.0f);
  for (float& v : image.real) v = value(rng);
  for (float& v : image.imag) v = value(rng);
  image.valid.assign(geometry.pixel_count(), 1);
  image.flags.assign(geometry.pixel_count(), 0);
  image.valid[3] = 0;
  image.flags[5] = kFlagOutlierFilled;
  image.flags[3] = kFlagSaturated;
  return image;
}

TEST(MomentFileWriter, FramesReadBackExactlyWithValidFlagsAndZerothHint) {
  ScratchDirectory dir;
  const ImageGeometry geometry{.width = 6, .height = 4};
  MomentFileHeader header{.geometry = geometry, .order = 3, .base_frequency_hz = 23e6,
                          .zeroth = ZerothScheme::kEstimated, .source = "capture.h5"};
  absl::StatusOr<MomentFileWriter> writer = MomentFileWriter::Create(dir.File("m.h5"), header);
  ASSERT_THAT(writer.status(), IsOk());
  const MomentImage first = RandomImage(geometry, 3, 1), second = RandomImage(geometry, 3, 2);
  ASSERT_THAT(writer->Append(first, 0.5), IsOk());
  ASSERT_THAT(writer->Append(second, 0.75), IsOk());
  ASSERT_THAT(writer->Close(), IsOk());

  absl::StatusOr<MomentFile> file = MomentFile::Open(dir.File("m.h5"));
  ASSERT_THAT(file.status(), IsOk());
  EXPECT_EQ(file->frames(), 2);
  EXPECT_EQ(file->order(), 3);
  EXPECT_EQ(file->base_frequency_hz(), 23e6);
  EXPECT_EQ(file->zeroth_hint(), ZerothMoment::kEstimate);
  MomentImage read;
  ASSERT_THAT(file->ReadFrame(1, &read), IsOk());
  EXPECT_THAT(read.real, ElementsAreArray(second.real));
  EXPECT_THAT(read.imag, ElementsAreArray(second.imag));
  EXPECT_THAT(read.valid, ElementsAreArray(second.valid));
  EXPECT_THAT(read.flags, ElementsAreArray(second.flags));
}

TEST(MomentFileWriter, MeasuredZerothIsRecordedAsSuch) {
  ScratchDirectory dir;
  MomentFileHeader header{.geometry = {.width = 2, .height = 2}, .order = 1,
                          .base_frequency_hz = 20e6};
  absl::StatusOr<MomentFileWriter> writer = MomentFileWriter::Create(dir.File("m.h5"), header);
  ASSERT_THAT(writer.status(), IsOk());
  ASSERT_THAT(writer->Append(MomentImage(header.geometry, 1), 0.0), IsOk());
  ASSERT_THAT(writer->Close(), IsOk());
  absl::StatusOr<MomentFile> file = MomentFile::Open(dir.File("m.h5"));
  ASSERT_THAT(file.status(), IsOk());
  EXPECT_EQ(file->zeroth_hint(), ZerothMoment::kMeasured);
}

TEST(MomentFileWriter, RefusesAFrameOfAnotherGeometryOrOrder) {
  ScratchDirectory dir;
  MomentFileHeader header{.geometry = {.width = 4, .height = 3}, .order = 2,
                          .base_frequency_hz = 20e6};
  absl::StatusOr<MomentFileWriter> writer = MomentFileWriter::Create(dir.File("m.h5"), header);
  ASSERT_THAT(writer.status(), IsOk());
  EXPECT_THAT(writer->Append(MomentImage({.width = 3, .height = 4}, 2), 0.0),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("3x4, m = 2")));
  EXPECT_THAT(writer->Append(MomentImage({.width = 4, .height = 3}, 3), 0.0),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("m = 3")));
  EXPECT_EQ(writer->frames(), 0);
}

TEST(MomentFileWriter, RefusesAPathThatCannotBeCreated) {
  EXPECT_THAT(MomentFileWriter::Create("/nonexistent-dir/m.h5",
                                       {.geometry = {.width = 1, .height = 1}, .order = 1,
                                        .base_frequency_hz = 1e6})
                  .status(),
              StatusIs(absl::StatusCode::kPermissionDenied, HasSubstr("/nonexistent-dir/m.h5")));
}

}  // namespace
}  // namespace transient::tools
