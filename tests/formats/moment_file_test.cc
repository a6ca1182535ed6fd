// MomentFile reads what the documented layout holds, in every accepted storage variant.
// The rejection of bad files is tested end to end in reconstruct_bad_input_test.cc.
#include "transient/formats/moment_file.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "tests/formats/test_files.h"
#include "transient/formats/h5.h"
#include "transient/reconstruct/moments.h"

namespace transient::tools {
namespace {

using ::testing::ElementsAreArray;
using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using testing::MomentStack;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;
using testing::StoredFloat;
using testing::StoredString;
using testing::WriteMomentFile;

// Float32 storage rounds each value to 24 bits: relative error <= 2^-24.
constexpr double kFloat32Rounding = 6e-8;

MomentStack RandomStack(int frames, int order, ImageGeometry geometry, uint64_t seed) {
  MomentStack stack(frames, order, geometry);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> value(-2.0, 2.0);
  for (double& v : stack.real) v = value(rng);
  for (double& v : stack.imag) v = value(rng);
  return stack;
}

// The values of frame `frame` in MomentImage order, rounded to float as the reader does.
std::vector<float> FramePlanes(const MomentStack& stack, const std::vector<double>& values,
                               int frame) {
  const int64_t count = (stack.order + 1) * stack.geometry.pixel_count();
  const auto begin = values.begin() + stack.index(frame, 0, 0);
  return std::vector<float>(begin, begin + count);
}

TEST(MomentFile, ReportsTheGeometryOrderFramesAndFrequencyOfTheFile) {
  ScratchDirectory dir;
  MomentStack stack = RandomStack(3, 5, {.width = 7, .height = 4}, 1);
  stack.base_frequency_hz = 31.5e6;
  WriteMomentFile(dir.File("in.h5"), stack);

  absl::StatusOr<MomentFile> file = MomentFile::Open(dir.File("in.h5"));
  ASSERT_THAT(file.status(), IsOk());
  EXPECT_EQ(file->frames(), 3);
  EXPECT_EQ(file->order(), 5);
  EXPECT_EQ(file->geometry(), (ImageGeometry{.width = 7, .height = 4}));
  EXPECT_EQ(file->base_frequency_hz(), 31.5e6);
  EXPECT_FALSE(file->has_valid_mask());
}

TEST(MomentFile, ReadsEachFrameOfFloat32DataExactly) {
  ScratchDirectory dir;
  const MomentStack stack = RandomStack(3, 2, {.width = 5, .height = 3}, 2);
  WriteMomentFile(dir.File("in.h5"), stack);
  absl::StatusOr<MomentFile> file = MomentFile::Open(dir.File("in.h5"));
  ASSERT_THAT(file.status(), IsOk());

  MomentImage image;
  for (int frame : {2, 0, 1}) {  // any order
    ASSERT_THAT(file->ReadFrame(frame, &image), IsOk());
    EXPECT_THAT(image.Validate(), IsOk());
    EXPECT_THAT(image.real, ElementsAreArray(FramePlanes(stack, stack.real, frame)));
    EXPECT_THAT(image.imag, ElementsAreArray(FramePlanes(stack, stack.imag, frame)));
    EXPECT_TRUE(image.valid.empty());
  }
}

TEST(MomentFile, ConvertsFloat64DataToFloat32) {
  ScratchDirectory dir;
  const MomentStack stack = RandomStack(2, 3, {.width = 4, .height = 4}, 3);
  WriteMomentFile(dir.File("in.h5"), stack, {.type = StoredFloat::kFloat64});
  absl::StatusOr<MomentFile> file = MomentFile::Open(dir.File("in.h5"));
  ASSERT_THAT(file.status(), IsOk());

  MomentImage image;
  ASSERT_THAT(file->ReadFrame(1, &image), IsOk());
  for (size_t i = 0; i < image.real.size(); ++i) {
    const double expected = stack.real[stack.index(1, 0, 0) + i];
    EXPECT_NEAR(image.real[i], expected, kFloat32Rounding * std::abs(expected));
  }
}

TEST(MomentFile, ReadsTheValidMaskOfEachFrame) {
  ScratchDirectory dir;
  MomentStack stack = RandomStack(2, 1, {.width = 3, .height = 2}, 4);
  stack.valid = {1, 0, 1, 1, 1, 1,   // frame 0
                 1, 1, 1, 1, 1, 0};  // frame 1
  WriteMomentFile(dir.File("in.h5"), stack);
  absl::StatusOr<MomentFile> file = MomentFile::Open(dir.File("in.h5"));
  ASSERT_THAT(file.status(), IsOk());
  EXPECT_TRUE(file->has_valid_mask());

  MomentImage image;
  ASSERT_THAT(file->ReadFrame(1, &image), IsOk());
  EXPECT_THAT(image.valid, ElementsAreArray({1, 1, 1, 1, 1, 0}));
  ASSERT_THAT(file->ReadFrame(0, &image), IsOk());
  EXPECT_THAT(image.valid, ElementsAreArray({1, 0, 1, 1, 1, 1}));
}

TEST(MomentFile, AcceptsABooleanMaskAsH5pyWritesIt) {
  ScratchDirectory dir;
  const std::string path = dir.File("in.h5");
  WriteMomentFile(path, RandomStack(1, 1, {.width = 2, .height = 2}, 5));
  {
    // h5py stores numpy bool as an enum {FALSE = 0, TRUE = 1} over int8.
    h5::Id file = h5::File(H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
    h5::Id type = h5::Datatype(H5Tenum_create(H5T_NATIVE_INT8));
    const int8_t no = 0, yes = 1;
    H5Tenum_insert(type.get(), "FALSE", &no);
    H5Tenum_insert(type.get(), "TRUE", &yes);
    const hsize_t dims[3] = {1, 2, 2};
    h5::Id space = h5::Dataspace(H5Screate_simple(3, dims, nullptr));
    h5::Id dataset = h5::Dataset(H5Dcreate2(file.get(), "/moments/valid", type.get(), space.get(),
                                            H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
    const int8_t values[4] = {1, 1, 0, 1};
    ASSERT_GE(H5Dwrite(dataset.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, values), 0);
  }
  absl::StatusOr<MomentFile> file = MomentFile::Open(path);
  ASSERT_THAT(file.status(), IsOk());
  MomentImage image;
  ASSERT_THAT(file->ReadFrame(0, &image), IsOk());
  EXPECT_THAT(image.valid, ElementsAreArray({1, 1, 0, 1}));
}

TEST(MomentFile, AcceptsAFixedLengthFormatStringAsMatlabWritesIt) {
  ScratchDirectory dir;
  WriteMomentFile(dir.File("in.h5"), RandomStack(1, 2, {.width = 2, .height = 2}, 6),
                  {.format_string = StoredString::kFixedLength});
  EXPECT_THAT(MomentFile::Open(dir.File("in.h5")).status(), IsOk());
}

TEST(MomentFile, AcceptsASpacePaddedFixedLengthFormatString) {
  ScratchDirectory dir;
  WriteMomentFile(
      dir.File("in.h5"), RandomStack(1, 2, {.width = 2, .height = 2}, 7),
      {.format_string = StoredString::kFixedLength, .format = "transient-moments 1     "});
  EXPECT_THAT(MomentFile::Open(dir.File("in.h5")).status(), IsOk());
}

TEST(MomentFile, AcceptsANewerMinorVersion) {
  ScratchDirectory dir;
  WriteMomentFile(dir.File("in.h5"), RandomStack(1, 2, {.width = 2, .height = 2}, 8),
                  {.format = "transient-moments 1.7"});
  EXPECT_THAT(MomentFile::Open(dir.File("in.h5")).status(), IsOk());
}

TEST(MomentFile, AcceptsTheLargestOrder) {
  ScratchDirectory dir;
  WriteMomentFile(dir.File("in.h5"), RandomStack(1, kMaxOrder, {.width = 2, .height = 1}, 9));
  absl::StatusOr<MomentFile> file = MomentFile::Open(dir.File("in.h5"));
  ASSERT_THAT(file.status(), IsOk());
  EXPECT_EQ(file->order(), kMaxOrder);
}

TEST(MomentFile, IgnoresExtraGroupsAndAttributes) {
  ScratchDirectory dir;
  const std::string path = dir.File("in.h5");
  WriteMomentFile(path, RandomStack(1, 2, {.width = 2, .height = 2}, 10));
  testing::ReplaceDataset(path, "/truth_range_m", H5T_IEEE_F32LE, {1, 2, 2});
  testing::SetStringAttribute(path, "/moments", "comment", "anything");
  EXPECT_THAT(MomentFile::Open(path).status(), IsOk());
}

TEST(MomentFile, RefusesToReadAFrameOutsideTheFile) {
  ScratchDirectory dir;
  WriteMomentFile(dir.File("in.h5"), RandomStack(2, 2, {.width = 2, .height = 2}, 11));
  absl::StatusOr<MomentFile> file = MomentFile::Open(dir.File("in.h5"));
  ASSERT_THAT(file.status(), IsOk());
  MomentImage image;
  EXPECT_THAT(file->ReadFrame(2, &image),
              StatusIs(absl::StatusCode::kOutOfRange, HasSubstr("frame 2")));
  EXPECT_THAT(file->ReadFrame(-1, &image), StatusIs(absl::StatusCode::kOutOfRange, HasSubstr("")));
}

}  // namespace
}  // namespace transient::tools
