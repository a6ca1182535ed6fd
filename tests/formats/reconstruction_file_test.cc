// The reconstruction file writer: layout, chunking per image plane, frame-by-frame writes.
#include "transient/formats/reconstruction_file.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "tests/formats/test_files.h"
#include "transient/formats/h5.h"

namespace transient::tools {
namespace {

using ::testing::Each;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using testing::ObjectExists;
using testing::ReadFloatDataset;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;

constexpr ImageGeometry kGeometry = {.width = 5, .height = 3};

ReconstructionHeader SmallHeader() {
  return {.frames = 3,
          .order = 2,
          .geometry = kGeometry,
          .phases = {0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 6.2},
          .base_frequency_hz = 20e6,
          .method = "both",
          .bias_epsilon = 4e-3,
          .bias_mode = "raise",
          .zeroth = "measured",
          .threshold = 0.1,
          .source = "in.h5"};
}

std::vector<hsize_t> ChunkOf(const std::string& path, const char* object) {
  h5::Id file = h5::File(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  h5::Id dataset = h5::Dataset(H5Dopen2(file.get(), object, H5P_DEFAULT));
  h5::Id creation = h5::PropertyList(H5Dget_create_plist(dataset.get()));
  std::vector<hsize_t> chunk(4, 0);
  const int rank = H5Pget_chunk(creation.get(), 4, chunk.data());
  chunk.resize(std::max(rank, 0));
  return chunk;
}

TEST(ReconstructionFile, ChunksEveryDatasetByImagePlane) {
  ScratchDirectory dir;
  const std::string path = dir.File("out.h5");
  absl::StatusOr<ReconstructionFile> file = ReconstructionFile::Create(path, SmallHeader());
  ASSERT_THAT(file.status(), IsOk());
  ASSERT_THAT(file->Close(), IsOk());
  EXPECT_THAT(ChunkOf(path, "/range_m"), ElementsAre(1, 3, 5));
  EXPECT_THAT(ChunkOf(path, "/flags"), ElementsAre(1, 3, 5));
  EXPECT_THAT(ChunkOf(path, "/density"), ElementsAre(1, 1, 3, 5));
  EXPECT_THAT(ChunkOf(path, "/pisarenko/phase"), ElementsAre(1, 1, 3, 5));
}

TEST(ReconstructionFile, WritesBlocksOfPlanesWhereTheyBelongAndNaNElsewhere) {
  ScratchDirectory dir;
  const std::string path = dir.File("out.h5");
  absl::StatusOr<ReconstructionFile> file = ReconstructionFile::Create(path, SmallHeader());
  ASSERT_THAT(file.status(), IsOk());
  const int64_t pixels = kGeometry.pixel_count();
  std::vector<float> block(3 * pixels);
  for (size_t i = 0; i < block.size(); ++i) block[i] = static_cast<float>(i);
  ASSERT_THAT(file->Write(Product::kDensity, /*frame=*/1, /*first_plane=*/2, block), IsOk());
  ASSERT_THAT(file->Close(), IsOk());

  const std::vector<float> density = ReadFloatDataset(path, "/density");
  for (int frame = 0; frame < 3; ++frame) {
    for (int plane = 0; plane < 8; ++plane) {
      for (int64_t p = 0; p < pixels; ++p) {
        const float value = density[(frame * 8 + plane) * pixels + p];
        if (frame == 1 && plane >= 2 && plane < 5) {
          EXPECT_EQ(value, static_cast<float>((plane - 2) * pixels + p));
        } else {
          EXPECT_TRUE(std::isnan(value)) << frame << " " << plane << " " << p;
        }
      }
    }
  }
}

TEST(ReconstructionFile, RefusesWritesOutsideTheDataset) {
  ScratchDirectory dir;
  absl::StatusOr<ReconstructionFile> file =
      ReconstructionFile::Create(dir.File("out.h5"), SmallHeader());
  ASSERT_THAT(file.status(), IsOk());
  const std::vector<float> plane(kGeometry.pixel_count(), 1.0f);
  const std::vector<float> two_planes(2 * kGeometry.pixel_count(), 1.0f);
  EXPECT_THAT(file->Write(Product::kRange, 3, 0, plane),
              StatusIs(absl::StatusCode::kInternal, HasSubstr("/range_m: bad write")));
  EXPECT_THAT(file->Write(Product::kRange, 0, 0, two_planes),
              StatusIs(absl::StatusCode::kInternal, HasSubstr("/range_m: bad write")));
  EXPECT_THAT(file->Write(Product::kPisarenkoPhase, 0, 1, two_planes),
              StatusIs(absl::StatusCode::kInternal, HasSubstr("bad write")));
  EXPECT_THAT(file->Write(Product::kBoundsLower, 0, 0, plane),
              StatusIs(absl::StatusCode::kInternal, HasSubstr("/bounds/lower")));
  EXPECT_THAT(file->Close(), IsOk());
}

TEST(ReconstructionFile, HoldsOnlyTheProductsOfTheHeader) {
  ScratchDirectory dir;
  const std::string path = dir.File("out.h5");
  ReconstructionHeader header = SmallHeader();
  header.mese = false;
  header.bounds_r = 0.5;
  absl::StatusOr<ReconstructionFile> file = ReconstructionFile::Create(path, header);
  ASSERT_THAT(file.status(), IsOk());
  EXPECT_FALSE(file->has(Product::kDensity));
  EXPECT_TRUE(file->has(Product::kBoundsUpper));
  ASSERT_THAT(file->Close(), IsOk());
  EXPECT_FALSE(ObjectExists(path, "/density"));
  EXPECT_FALSE(ObjectExists(path, "/cumulative"));
  EXPECT_TRUE(ObjectExists(path, "/phase_rad"));  // the bounds' phases
  EXPECT_TRUE(ObjectExists(path, "/bounds/lower"));
  EXPECT_TRUE(ObjectExists(path, "/pisarenko/indirect"));
  EXPECT_THAT(ReadFloatDataset(path, "/phase_rad"),
              ElementsAre(0.0f, 1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f, 6.2f));
  EXPECT_THAT(ReadFloatDataset(path, "/pisarenko/indirect"), Each(::testing::IsNan()));
}

TEST(ReconstructionFile, EachProductHasItsPlanesAndItsBlock) {
  EXPECT_EQ(PlaneCount(ProductPlanes::kOne, 64, 3), 1);
  EXPECT_EQ(PlaneCount(ProductPlanes::kBins, 64, 3), 64);
  EXPECT_EQ(PlaneCount(ProductPlanes::kOrder, 64, 3), 3);
  const ProductLayout& range = kProductLayouts[static_cast<int>(Product::kRange)];
  const ProductLayout& density = kProductLayouts[static_cast<int>(Product::kDensity)];
  // One-plane products are [frames, H, W]; the plane arguments do not apply to them.
  ProductBlock block = BlockOf(range, 7, 0, 1, kGeometry);
  EXPECT_THAT(block.start, ElementsAre(7, 0, 0));
  EXPECT_THAT(block.count, ElementsAre(1, 3, 5));
  // Stacks are [frames, planes, H, W]: planes 2 and 3 of frame 7.
  block = BlockOf(density, 7, 2, 2, kGeometry);
  EXPECT_THAT(block.start, ElementsAre(7, 2, 0, 0));
  EXPECT_THAT(block.count, ElementsAre(1, 2, 3, 5));
}

TEST(ReconstructionFile, EveryGroupOfProductsComesWithItsSetting) {
  for (const ProductLayout& layout : kProductLayouts) {
    SCOPED_TRACE(layout.path);
    const std::string path = layout.path;
    switch (layout.group) {
      case ProductGroup::kAlways:
        EXPECT_EQ(path.find('/', 1), std::string::npos);  // at the root
        break;
      case ProductGroup::kMese:
        EXPECT_EQ(layout.planes, ProductPlanes::kBins);
        break;
      case ProductGroup::kPisarenko:
        EXPECT_EQ(path.rfind("/pisarenko/", 0), 0u);
        break;
      case ProductGroup::kBounds:
        EXPECT_EQ(path.rfind("/bounds/", 0), 0u);
        break;
    }
  }
}

}  // namespace
}  // namespace transient::tools
