// The HDF5 helper layer: each check accepts what the formats write and refuses, by file, object
// and rule, what they must not read; block reads and writes land where they say.
#include "transient/formats/h5.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"

namespace transient {
namespace {

using ::testing::ElementsAre;
using ::testing::ElementsAreArray;
using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;

constexpr absl::StatusCode kInvalid = absl::StatusCode::kInvalidArgument;

// An absl::StatusOr that is OK and holds a value `matcher` accepts.
MATCHER_P(HoldsValue, matcher, "is OK and holds a matching value") {
  if (!arg.ok()) {
    *result_listener << "status " << arg.status();
    return false;
  }
  return ::testing::ExplainMatchResult(matcher, *arg, result_listener);
}

// A new, empty HDF5 file open for writing; the test fails when it cannot be made.
h5::Id NewFile(const std::string& path) {
  h5::SilenceErrorStack();
  h5::Id file = h5::File(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT));
  EXPECT_TRUE(file.valid()) << path;
  return file;
}

// A dataset of `type` and shape `dims`, unwritten (it reads as zeros).
void MakeDataset(hid_t file, const char* name, hid_t type, std::vector<hsize_t> dims) {
  absl::StatusOr<h5::Id> dataset = h5::CreateDataset(file, name, type, {.dims = dims});
  ASSERT_THAT(dataset.status(), IsOk()) << name;
}

// h5py's numpy bool: a one-byte enum FALSE = 0, TRUE = 1.
h5::Id BoolEnum() {
  h5::Id type = h5::Datatype(H5Tenum_create(H5T_NATIVE_INT8));
  int8_t value = 0;
  H5Tenum_insert(type.get(), "FALSE", &value);
  value = 1;
  H5Tenum_insert(type.get(), "TRUE", &value);
  return type;
}

TEST(H5, WhereAndDescriptionsNameWhatMessagesTalkAbout) {
  EXPECT_EQ(h5::Where("in.h5", "/moments/real"), "in.h5: /moments/real");
  EXPECT_EQ(h5::DimensionsToString({2, 4, 12, 16}), "[2, 4, 12, 16]");
  EXPECT_EQ(h5::DimensionsToString({}), "[]");
  EXPECT_EQ(h5::DescribeType(H5T_IEEE_F32LE), "float32");
  EXPECT_EQ(h5::DescribeType(H5T_STD_U8LE), "uint8");
  EXPECT_EQ(h5::DescribeType(H5T_STD_I64LE), "int64");
  EXPECT_EQ(h5::DescribeType(BoolEnum().get()), "enum (1 byte)");
}

TEST(H5, CheckReadableFileNamesTheCommonMistakes) {
  ScratchDirectory scratch;
  std::filesystem::create_directory(scratch.File("dir"));
  std::ofstream(scratch.File("text.h5")) << "not HDF5";
  { NewFile(scratch.File("good.h5")); }
  EXPECT_THAT(h5::CheckReadableFile(scratch.File("good.h5")), IsOk());
  EXPECT_THAT(h5::CheckReadableFile(scratch.File("none.h5")),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("none.h5: no such file")));
  EXPECT_THAT(h5::CheckReadableFile(scratch.File("dir"), "an HDF5 moment file"),
              StatusIs(kInvalid, HasSubstr("dir: is a directory, expected an HDF5 moment file")));
  EXPECT_THAT(h5::CheckReadableFile(scratch.File("text.h5")),
              StatusIs(kInvalid, HasSubstr("text.h5: not an HDF5 file")));
}

TEST(H5, OpenFileForReadingOpensAFileAndRefusesWhatIsNotOne) {
  ScratchDirectory scratch;
  { NewFile(scratch.File("good.h5")); }
  std::ofstream(scratch.File("text.h5")) << "not HDF5";
  for (h5::SwmrRead swmr : {h5::SwmrRead::kRefuse, h5::SwmrRead::kAllow}) {
    absl::StatusOr<h5::Id> file = h5::OpenFileForReading(scratch.File("good.h5"), "x", swmr);
    ASSERT_THAT(file.status(), IsOk());
    EXPECT_TRUE(file->valid());
    EXPECT_THAT(h5::OpenFileForReading(scratch.File("none.h5"), "x", swmr).status(),
                StatusIs(absl::StatusCode::kNotFound, ::testing::_));
    EXPECT_THAT(h5::OpenFileForReading(scratch.File("text.h5"), "x", swmr).status(),
                StatusIs(kInvalid, HasSubstr("not an HDF5 file")));
  }
}

TEST(H5, OpenFileForReadingGetsPastSwmrMarksOnlyWhenAllowed) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("swmr.h5");
  {
    // A file in SWMR-write mode, left as a killed writer leaves it: its superblock keeps the
    // "open for writing" marks that a plain open refuses.
    h5::Id access = h5::PropertyList(H5Pcreate(H5P_FILE_ACCESS));
    H5Pset_libver_bounds(access.get(), H5F_LIBVER_LATEST, H5F_LIBVER_LATEST);
    h5::Id file = h5::File(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, access.get()));
    ASSERT_TRUE(file.valid());
    ASSERT_THAT(h5::WriteStringAttribute(file.get(), "format", "x 1"), IsOk());
    ASSERT_GE(H5Fstart_swmr_write(file.get()), 0);
    ASSERT_GE(H5Fflush(file.get(), H5F_SCOPE_GLOBAL), 0);
    // Copied while open: the copy is the file as a crash would leave it.
    std::filesystem::copy_file(path, scratch.File("killed.h5"));
  }
  const std::string killed = scratch.File("killed.h5");
  EXPECT_THAT(h5::OpenFileForReading(killed, "x", h5::SwmrRead::kRefuse).status(),
              StatusIs(absl::StatusCode::kDataLoss, HasSubstr("HDF5 cannot open the file")));
  absl::StatusOr<h5::Id> file = h5::OpenFileForReading(killed, "x", h5::SwmrRead::kAllow);
  ASSERT_THAT(file.status(), IsOk());
  EXPECT_THAT(h5::ReadStringAttribute(file->get(), "format", "killed.h5: /"),
              HoldsValue(std::string("x 1")));
}

TEST(H5, OpenObjectTellsMissingFromAnotherKind) {
  ScratchDirectory scratch;
  h5::Id file = NewFile(scratch.File("f.h5"));
  h5::Id group = h5::Group(H5Gcreate2(file.get(), "/g", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  MakeDataset(file.get(), "/d", H5T_IEEE_F32LE, {2});
  EXPECT_THAT(h5::OpenGroup(file.get(), "f.h5", "/g").status(), IsOk());
  EXPECT_THAT(h5::OpenGroup(file.get(), "f.h5", "/").status(), IsOk());
  EXPECT_THAT(h5::OpenGroup(file.get(), "f.h5", "/nothing/below").status(),
              StatusIs(kInvalid, HasSubstr("f.h5: /nothing/below: missing group")));
  EXPECT_THAT(h5::OpenGroup(file.get(), "f.h5", "/d").status(),
              StatusIs(kInvalid, HasSubstr("f.h5: /d: expected a group, found another kind")));
  EXPECT_TRUE(h5::LinkExists(file.get(), "/g"));
  EXPECT_FALSE(h5::LinkExists(file.get(), "/g/missing/deeper"));
}

TEST(H5, OpenDatasetChecksTypeRankAndFilters) {
  ScratchDirectory scratch;
  h5::Id file = NewFile(scratch.File("f.h5"));
  MakeDataset(file.get(), "/f32", H5T_IEEE_F32LE, {2, 3});
  MakeDataset(file.get(), "/f64", H5T_IEEE_F64LE, {2, 3});
  MakeDataset(file.get(), "/i16", H5T_STD_I16LE, {2, 3});
  MakeDataset(file.get(), "/u8", H5T_STD_U8LE, {2, 3});
  MakeDataset(file.get(), "/bool", BoolEnum().get(), {2, 3});
  h5::Id group = h5::Group(H5Gcreate2(file.get(), "/g", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  std::vector<hsize_t> dims;
  const auto open = [&](const char* object, const h5::TypeRule& type, int rank) {
    return h5::OpenDataset(file.get(), "f.h5", object, type, rank, "[height, width]", &dims)
        .status();
  };
  EXPECT_THAT(open("/f32", h5::kFloat32, 2), IsOk());
  EXPECT_THAT(dims, ElementsAre(2, 3));
  EXPECT_THAT(open("/f64", h5::kAnyFloat, 2), IsOk());
  EXPECT_THAT(open("/i16", h5::kAnyInteger, 2), IsOk());
  EXPECT_THAT(open("/u8", h5::kByte, 2), IsOk());
  EXPECT_THAT(open("/bool", h5::kByte, 2), IsOk());  // h5py's bool where a byte is expected
  EXPECT_THAT(open("/i16", {H5T_NO_CLASS, 0, "anything"}, 2), IsOk());

  EXPECT_THAT(open("/f64", h5::kFloat32, 2),
              StatusIs(kInvalid, HasSubstr("f.h5: /f64: expected float32, found float64")));
  EXPECT_THAT(
      open("/i16", h5::kAnyFloat, 2),
      StatusIs(kInvalid, HasSubstr("f.h5: /i16: expected float32 or float64, found int16")));
  EXPECT_THAT(open("/i16", h5::kByte, 2),
              StatusIs(kInvalid, HasSubstr("f.h5: /i16: expected uint8, found int16")));
  EXPECT_THAT(open("/bool", {H5T_INTEGER, 1, "uint8"}, 2),  // no bool_enum
              StatusIs(kInvalid, HasSubstr("expected uint8, found enum (1 byte)")));
  EXPECT_THAT(open("/f32", h5::kFloat32, 3),
              StatusIs(kInvalid, HasSubstr("f.h5: /f32: expected 3 dimensions [height, width], "
                                           "found 2")));
  EXPECT_THAT(open("/f32", h5::kFloat32, 1),
              StatusIs(kInvalid, HasSubstr("expected 1 dimension [height, width], found 2")));
  EXPECT_THAT(
      open("/none", h5::kFloat32, 2),
      StatusIs(kInvalid, HasSubstr("f.h5: /none: missing dataset (float32, [height, width])")));
  EXPECT_THAT(open("/g", h5::kFloat32, 2),
              StatusIs(kInvalid, HasSubstr("f.h5: /g: expected a dataset (float32, [height, "
                                           "width]), found another kind of object")));
}

TEST(H5, OpenDatasetRefusesAFilterThisLibraryCannotDecode) {
  ScratchDirectory scratch;
  h5::Id file = NewFile(scratch.File("f.h5"));
  // h5py's lzf (filter 32000) is not in Debian's HDF5; an optional filter lets the file be
  // written without it.
  constexpr H5Z_filter_t kLzf = 32000;
  ASSERT_LE(H5Zfilter_avail(kLzf), 0) << "this HDF5 decodes lzf; the test needs a missing filter";
  h5::Id creation = h5::PropertyList(H5Pcreate(H5P_DATASET_CREATE));
  const hsize_t dims[1] = {4};
  H5Pset_chunk(creation.get(), 1, dims);
  ASSERT_GE(H5Pset_filter(creation.get(), kLzf, H5Z_FLAG_OPTIONAL, 0, nullptr), 0);
  h5::Id space = h5::Dataspace(H5Screate_simple(1, dims, nullptr));
  h5::Id dataset = h5::Dataset(H5Dcreate2(file.get(), "/lzf", H5T_IEEE_F32LE, space.get(),
                                          H5P_DEFAULT, creation.get(), H5P_DEFAULT));
  ASSERT_TRUE(dataset.valid());
  std::vector<hsize_t> found;
  EXPECT_THAT(h5::OpenDataset(file.get(), "f.h5", "/lzf", h5::kFloat32, 1, "[n]", &found).status(),
              StatusIs(kInvalid, HasSubstr("f.h5: /lzf: stored with HDF5 filter 32000")));
}

TEST(H5, CheckShapeAcceptsOnlyTheExpectedShape) {
  EXPECT_THAT(h5::CheckShape("f.h5: /d", {2, 3}, {2, 3}, "[height, width]"), IsOk());
  EXPECT_THAT(h5::CheckShape("f.h5: /d", {3, 2}, {2, 3}, "[height, width]"),
              StatusIs(kInvalid, HasSubstr("f.h5: /d: expected shape [height, width] = [2, 3], "
                                           "found [3, 2]")));
  EXPECT_THAT(h5::CheckShape("f.h5: /d", {2, 3, 1}, {2, 3}, "[height, width]"),
              StatusIs(kInvalid, HasSubstr("found [2, 3, 1]")));
}

TEST(H5, CheckImageSizeAcceptsOneToTheLargestImage) {
  EXPECT_THAT(h5::CheckImageSize("w", 1, 1), IsOk());
  EXPECT_THAT(h5::CheckImageSize("w", 16384, 16384), IsOk());  // exactly kMaxImagePixels
  EXPECT_THAT(h5::CheckImageSize("w", 1, h5::kMaxImagePixels), IsOk());
  EXPECT_THAT(h5::CheckImageSize("w", 0, 4),
              StatusIs(kInvalid, HasSubstr("w: expected a non-empty image, found height 0 and "
                                           "width 4")));
  EXPECT_THAT(h5::CheckImageSize("w", 4, 0), StatusIs(kInvalid, HasSubstr("non-empty")));
  EXPECT_THAT(h5::CheckImageSize("w", 16384, 16385),
              StatusIs(kInvalid, HasSubstr("w: expected at most 268435456 pixels per image, "
                                           "found 16384 x 16385")));
  // Factors whose product overflows 64 bits are refused, not wrapped around.
  EXPECT_THAT(h5::CheckImageSize("w", uint64_t{1} << 32, uint64_t{1} << 32),
              StatusIs(kInvalid, HasSubstr("at most")));
  EXPECT_THAT(h5::CheckImageSize("w", 2, h5::kMaxImagePixels), StatusIs(kInvalid, ::testing::_));
}

TEST(H5, AttributesRoundTripAndReplaceTheirNamesake) {
  ScratchDirectory scratch;
  h5::Id file = NewFile(scratch.File("f.h5"));
  const hid_t root = file.get();
  ASSERT_THAT(h5::WriteStringAttribute(root, "s", "first"), IsOk());
  ASSERT_THAT(h5::WriteStringAttribute(root, "s", "µ-second"), IsOk());
  ASSERT_THAT(h5::WriteDoubleAttribute(root, "d", -2.5), IsOk());
  ASSERT_THAT(h5::WriteInt64Attribute(root, "i", int64_t{1} << 40), IsOk());
  ASSERT_THAT(h5::WriteDoubleArrayAttribute(root, "a", {1, 2, 3}), IsOk());
  ASSERT_THAT(h5::WriteDoubleArrayAttribute(root, "a", {4, 5}), IsOk());
  EXPECT_THAT(h5::ReadStringAttribute(root, "s", "f.h5: /"), HoldsValue(std::string("µ-second")));
  EXPECT_THAT(h5::ReadNumericAttribute(root, "d", "f.h5: /"), HoldsValue(-2.5));
  EXPECT_THAT(h5::ReadNumericAttribute(root, "i", "f.h5: /"),
              HoldsValue(static_cast<double>(int64_t{1} << 40)));
  EXPECT_THAT(h5::ReadIntegerAttribute(root, "i", "f.h5: /", 0, int64_t{1} << 40),
              HoldsValue(int64_t{1} << 40));
  EXPECT_THAT(h5::ReadDoubleArrayAttribute(root, "a", "f.h5: /", 2),
              HoldsValue(ElementsAre(4.0, 5.0)));
}

TEST(H5, AttributeReadsRefuseMissingMistypedAndOutOfRangeValues) {
  ScratchDirectory scratch;
  h5::Id file = NewFile(scratch.File("f.h5"));
  const hid_t root = file.get();
  ASSERT_THAT(h5::WriteStringAttribute(root, "text", "23 MHz"), IsOk());
  ASSERT_THAT(h5::WriteDoubleAttribute(root, "half", 7.5), IsOk());
  ASSERT_THAT(h5::WriteDoubleAttribute(root, "nan", std::nan("")), IsOk());
  ASSERT_THAT(h5::WriteDoubleAttribute(root, "inf", std::numeric_limits<double>::infinity()),
              IsOk());
  ASSERT_THAT(h5::WriteDoubleAttribute(root, "zero", 0.0), IsOk());
  ASSERT_THAT(h5::WriteDoubleAttribute(root, "negative", -1.0), IsOk());
  ASSERT_THAT(h5::WriteDoubleArrayAttribute(root, "pair", {1, 2}), IsOk());
  const std::string where = "f.h5: /";

  EXPECT_THAT(h5::ReadStringAttribute(root, "none", where).status(),
              StatusIs(kInvalid, HasSubstr("f.h5: /: missing attribute none")));
  EXPECT_THAT(h5::ReadStringAttribute(root, "half", where).status(),
              StatusIs(kInvalid, HasSubstr("attribute half: expected a string, found float64")));
  EXPECT_THAT(h5::ReadStringAttribute(root, "pair", where).status(),
              StatusIs(kInvalid, HasSubstr("attribute pair: expected a single value, found [2]")));
  EXPECT_THAT(h5::ReadNumericAttribute(root, "text", where).status(),
              StatusIs(kInvalid, HasSubstr("attribute text: expected a number (float64), found "
                                           "string")));

  using h5::Sign;
  EXPECT_THAT(h5::ReadFiniteAttribute(root, "negative", where, Sign::kAny), HoldsValue(-1.0));
  EXPECT_THAT(h5::ReadFiniteAttribute(root, "zero", where, Sign::kNonNegative), HoldsValue(0.0));
  EXPECT_THAT(
      h5::ReadFiniteAttribute(root, "zero", where, Sign::kPositive).status(),
      StatusIs(kInvalid, HasSubstr("attribute zero: expected a finite value > 0, found 0")));
  EXPECT_THAT(h5::ReadFiniteAttribute(root, "negative", where, Sign::kNonNegative).status(),
              StatusIs(kInvalid, HasSubstr("expected a finite value >= 0, found -1")));
  for (const char* name : {"nan", "inf"}) {
    EXPECT_THAT(h5::ReadFiniteAttribute(root, name, where, Sign::kAny).status(),
                StatusIs(kInvalid, HasSubstr("expected a finite value, found")))
        << name;
  }

  EXPECT_THAT(h5::ReadIntegerAttribute(root, "negative", where, -1, 1), HoldsValue(int64_t{-1}));
  EXPECT_THAT(h5::ReadIntegerAttribute(root, "half", where, 1, 16).status(),
              StatusIs(kInvalid, HasSubstr("attribute half: expected an integer in 1..16, found "
                                           "7.5")));
  EXPECT_THAT(h5::ReadIntegerAttribute(root, "negative", where, 0, 16).status(),
              StatusIs(kInvalid, HasSubstr("expected an integer in 0..16, found -1")));
  EXPECT_THAT(h5::ReadIntegerAttribute(root, "nan", where, 0, 16).status(),
              StatusIs(kInvalid, HasSubstr("found nan")));

  EXPECT_THAT(h5::ReadDoubleArrayAttribute(root, "pair", where, 5).status(),
              StatusIs(kInvalid, HasSubstr("attribute pair: expected 5 float64 values, found "
                                           "float64 [2]")));
  EXPECT_THAT(h5::ReadDoubleArrayAttribute(root, "text", where, 1).status(),
              StatusIs(kInvalid, HasSubstr("expected 1 float64 values, found string []")));
  EXPECT_THAT(h5::ReadDoubleArrayAttribute(root, "none", where, 1).status(),
              StatusIs(kInvalid, HasSubstr("missing attribute none")));
}

TEST(H5, WholeDatasetsRoundTrip) {
  ScratchDirectory scratch;
  h5::Id file = NewFile(scratch.File("f.h5"));
  const std::vector<float> values = {1, 2, 3, 4, 5, 6};
  ASSERT_THAT(
      h5::WriteDataset(file.get(), "d", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, {2, 3}, values.data()),
      IsOk());
  std::vector<hsize_t> dims;
  absl::StatusOr<h5::Id> dataset =
      h5::OpenDataset(file.get(), "f.h5", "/d", h5::kFloat32, 2, "[2, 3]", &dims);
  ASSERT_THAT(dataset.status(), IsOk());
  std::vector<double> read(6);
  ASSERT_THAT(h5::ReadDataset(dataset->get(), H5T_NATIVE_DOUBLE, read.data(), "f.h5: /d"), IsOk());
  EXPECT_THAT(read, ElementsAre(1, 2, 3, 4, 5, 6));
  // A name that is taken cannot be created again.
  EXPECT_THAT(
      h5::WriteDataset(file.get(), "d", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, {2, 3}, values.data()),
      StatusIs(absl::StatusCode::kInternal, HasSubstr("cannot create dataset d")));
}

TEST(H5, CreateDatasetAppliesTheLayoutAndRefusesAnInconsistentOne) {
  ScratchDirectory scratch;
  h5::Id file = NewFile(scratch.File("f.h5"));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  absl::StatusOr<h5::Id> dataset = h5::CreateDataset(file.get(), "chunked", H5T_IEEE_F32LE,
                                                     {.dims = {2, 3},
                                                      .chunk = {1, 3},
                                                      .fill_type = H5T_NATIVE_FLOAT,
                                                      .fill = &nan,
                                                      .deflate_level = 4});
  ASSERT_THAT(dataset.status(), IsOk());
  h5::Id creation = h5::PropertyList(H5Dget_create_plist(dataset->get()));
  hsize_t chunk[2] = {};
  EXPECT_EQ(H5Pget_layout(creation.get()), H5D_CHUNKED);
  ASSERT_EQ(H5Pget_chunk(creation.get(), 2, chunk), 2);
  EXPECT_THAT(chunk, ElementsAre(1, 3));
  EXPECT_EQ(H5Pget_nfilters(creation.get()), 2);  // shuffle and deflate
  std::vector<float> unwritten(6, 0.0f);
  ASSERT_THAT(h5::ReadDataset(dataset->get(), H5T_NATIVE_FLOAT, unwritten.data(), "w"), IsOk());
  for (float v : unwritten) EXPECT_TRUE(std::isnan(v));  // the fill value

  const auto refused = [&](const h5::DatasetLayout& layout) {
    return h5::CreateDataset(file.get(), "bad", H5T_IEEE_F32LE, layout).status();
  };
  EXPECT_THAT(refused({.dims = {2, 3}, .max_dims = {H5S_UNLIMITED}}),
              StatusIs(absl::StatusCode::kInternal, HasSubstr("cannot create dataset bad")));
  EXPECT_THAT(refused({.dims = {2, 3}, .chunk = {1}}),
              StatusIs(absl::StatusCode::kInternal, ::testing::_));
  EXPECT_THAT(refused({.dims = {2, 3}, .deflate_level = 1}),  // deflate needs chunks
              StatusIs(absl::StatusCode::kInternal, ::testing::_));
  EXPECT_THAT(refused({.dims = {0, 3}, .max_dims = {H5S_UNLIMITED, 3}}),  // extendible, unchunked
              StatusIs(absl::StatusCode::kInternal, ::testing::_));
  EXPECT_FALSE(h5::LinkExists(file.get(), "/bad"));
}

TEST(H5, BlocksLandWhereTheySayAndBadBlocksAreRefused) {
  ScratchDirectory scratch;
  h5::Id file = NewFile(scratch.File("f.h5"));
  absl::StatusOr<h5::Id> dataset =
      h5::CreateDataset(file.get(), "d", H5T_IEEE_F32LE, {.dims = {3, 2, 2}});
  ASSERT_THAT(dataset.status(), IsOk());
  const std::vector<float> plane = {1, 2, 3, 4};
  ASSERT_THAT(h5::WriteBlock(dataset->get(), {1, 0, 0}, {1, 2, 2}, H5T_NATIVE_FLOAT, plane.data()),
              IsOk());
  std::vector<float> all(12, -1.0f);
  ASSERT_THAT(h5::ReadDataset(dataset->get(), H5T_NATIVE_FLOAT, all.data(), "w"), IsOk());
  EXPECT_THAT(all, ElementsAreArray<float>({0, 0, 0, 0, 1, 2, 3, 4, 0, 0, 0, 0}));
  std::vector<float> column(2, -1.0f);
  ASSERT_THAT(h5::ReadBlock(dataset->get(), {1, 0, 1}, {1, 2, 1}, H5T_NATIVE_FLOAT, column.data()),
              IsOk());
  EXPECT_THAT(column, ElementsAre(2, 4));

  std::vector<float> buffer(8);
  // Outside the dataset, or of another rank.
  EXPECT_THAT(
      h5::ReadBlock(dataset->get(), {2, 0, 0}, {2, 2, 2}, H5T_NATIVE_FLOAT, buffer.data()),
      StatusIs(absl::StatusCode::kDataLoss, HasSubstr("cannot read the block at [2, 0, 0]")));
  EXPECT_THAT(h5::ReadBlock(dataset->get(), {0, 0}, {1, 2}, H5T_NATIVE_FLOAT, buffer.data()),
              StatusIs(absl::StatusCode::kDataLoss, ::testing::_));
  EXPECT_THAT(h5::WriteBlock(dataset->get(), {3, 0, 0}, {1, 2, 2}, H5T_NATIVE_FLOAT, plane.data()),
              StatusIs(absl::StatusCode::kInternal, HasSubstr("cannot write the block")));
  EXPECT_THAT(h5::WriteBlock(dataset->get(), {0, 0, 0}, {1, 2}, H5T_NATIVE_FLOAT, plane.data()),
              StatusIs(absl::StatusCode::kInternal, ::testing::_));
}

TEST(H5, AppendAlongFirstGrowsAnExtendibleDatasetByOneEntry) {
  ScratchDirectory scratch;
  h5::Id file = NewFile(scratch.File("f.h5"));
  absl::StatusOr<h5::Id> planes =
      h5::CreateDataset(file.get(), "planes", H5T_IEEE_F32LE,
                        {.dims = {0, 1, 2}, .max_dims = {H5S_UNLIMITED, 1, 2}, .chunk = {1, 1, 2}});
  ASSERT_THAT(planes.status(), IsOk());
  for (hsize_t i = 0; i < 3; ++i) {
    const float plane[2] = {static_cast<float>(10 * i), static_cast<float>(10 * i + 1)};
    ASSERT_THAT(h5::AppendAlongFirst(planes->get(), i, H5T_NATIVE_FLOAT, plane), IsOk());
  }
  h5::Id space = h5::Dataspace(H5Dget_space(planes->get()));
  EXPECT_THAT(h5::Dimensions(space.get()), ElementsAre(3, 1, 2));
  std::vector<float> all(6);
  ASSERT_THAT(h5::ReadDataset(planes->get(), H5T_NATIVE_FLOAT, all.data(), "w"), IsOk());
  EXPECT_THAT(all, ElementsAre(0, 1, 10, 11, 20, 21));

  // A fixed-size dataset cannot grow; a scalar has no first dimension.
  absl::StatusOr<h5::Id> fixed =
      h5::CreateDataset(file.get(), "fixed", H5T_IEEE_F32LE, {.dims = {1}});
  ASSERT_THAT(fixed.status(), IsOk());
  const float value = 1.0f;
  EXPECT_THAT(h5::AppendAlongFirst(fixed->get(), 1, H5T_NATIVE_FLOAT, &value),
              StatusIs(absl::StatusCode::kInternal, HasSubstr("cannot extend")));
  h5::Id scalar_space = h5::Dataspace(H5Screate(H5S_SCALAR));
  h5::Id scalar = h5::Dataset(H5Dcreate2(file.get(), "scalar", H5T_IEEE_F32LE, scalar_space.get(),
                                         H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  EXPECT_THAT(h5::AppendAlongFirst(scalar.get(), 0, H5T_NATIVE_FLOAT, &value),
              StatusIs(absl::StatusCode::kInternal, HasSubstr("scalar")));
}

TEST(H5, IdsCloseOnceAndReportAFailedClose) {
  ScratchDirectory scratch;
  h5::Id file = NewFile(scratch.File("f.h5"));
  h5::Id moved = std::move(file);
  EXPECT_FALSE(file.valid());  // NOLINT(bugprone-use-after-move): the state after a move
  EXPECT_TRUE(moved.valid());
  EXPECT_THAT(moved.Close(), IsOk());
  EXPECT_FALSE(moved.valid());
  EXPECT_THAT(moved.Close(), IsOk());  // nothing left to close
  h5::Id bogus(123456789, H5Fclose);   // not an identifier HDF5 knows
  EXPECT_THAT(bogus.Close(), StatusIs(absl::StatusCode::kInternal, ::testing::_));
}

}  // namespace
}  // namespace transient
