// Capture files: every field round-trips, and files of another format or layout are refused
// with a message naming the object and the rule.
#include "transient/formats/capture_file.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <vector>

#include "tests/formats/test_captures.h"
#include "tests/support/scratch_directory.h"
#include "tests/support/status_matchers.h"
#include "transient/formats/h5.h"

namespace transient {
namespace {

using ::testing::HasSubstr;
using testing::TestCalibration;
using testing::TestCamera;
using testing::TestFrame;
using testing::TestGroundTruth;
using testing::TestOptions;
using testing::TestSchedule;
using testing::WriteTestCapture;
using ::transient::testing::IsOk;
using ::transient::testing::ScratchDirectory;
using ::transient::testing::StatusIs;

// Bit-exact float comparison that treats NaN as equal to NaN.
bool SameBits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

void ExpectSameConfig(const ExposureConfig& a, const ExposureConfig& b) {
  EXPECT_EQ(a.harmonic, b.harmonic);
  EXPECT_EQ(a.frequency_hz, b.frequency_hz);
  EXPECT_EQ(a.phase_shift_rad, b.phase_shift_rad);
  EXPECT_EQ(a.exposure_s, b.exposure_s);
  EXPECT_EQ(a.illumination, b.illumination);
  EXPECT_EQ(a.take, b.take);
  EXPECT_EQ(a.cycle, b.cycle);
  EXPECT_EQ(a.sequence, b.sequence);
  EXPECT_EQ(a.timestamp_s, b.timestamp_s);
}

class CaptureRoundTrip : public ::testing::TestWithParam<std::pair<CapturePixelType, int>> {};

TEST_P(CaptureRoundTrip, EveryFieldComesBackBitExact) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("capture.h5");
  const auto [type, deflate] = GetParam();
  const bool integer = type == CapturePixelType::kUint16;
  constexpr int64_t kFrames = 23;
  WriteTestCapture(path, kFrames, TestOptions(type, deflate));

  absl::StatusOr<CaptureReader> reader = CaptureReader::Open(path);
  ASSERT_THAT(reader.status(), IsOk());
  const CameraInfo camera = TestCamera();
  const AcquisitionSchedule schedule = TestSchedule();
  EXPECT_EQ(reader->frames(), kFrames);
  EXPECT_EQ(reader->pixel_type(), type);
  EXPECT_EQ(reader->source_uri(), "sim:test?m=2");
  EXPECT_EQ(reader->camera().geometry, camera.geometry);
  EXPECT_EQ(reader->camera().intrinsics.fx, camera.intrinsics.fx);
  EXPECT_EQ(reader->camera().intrinsics.fy, camera.intrinsics.fy);
  EXPECT_EQ(reader->camera().intrinsics.cx, camera.intrinsics.cx);
  EXPECT_EQ(reader->camera().intrinsics.cy, camera.intrinsics.cy);
  EXPECT_EQ(reader->camera().distortion, camera.distortion);
  EXPECT_EQ(reader->camera().model, camera.model);
  EXPECT_EQ(reader->camera().frame_period_s, camera.frame_period_s);
  const ScheduleOptions& got = reader->schedule().options();
  const ScheduleOptions& want = schedule.options();
  EXPECT_EQ(got.base_frequency_hz, want.base_frequency_hz);
  EXPECT_EQ(got.order, want.order);
  EXPECT_EQ(got.sampling, want.sampling);
  EXPECT_EQ(got.phase_steps, want.phase_steps);
  EXPECT_EQ(got.zeroth, want.zeroth);
  EXPECT_EQ(got.proxy_frequency_hz, want.proxy_frequency_hz);
  EXPECT_EQ(got.exposure_s, want.exposure_s);
  EXPECT_EQ(got.takes, want.takes);
  EXPECT_EQ(reader->schedule().raw_frames_per_frame(), schedule.raw_frames_per_frame());
  EXPECT_FALSE(reader->ground_truth().has_value());
  EXPECT_FALSE(reader->calibration().has_value());

  RawFrame frame;
  for (int64_t i = 0; i < kFrames; ++i) {
    ASSERT_THAT(reader->Read(i, &frame), IsOk());
    const RawFrame want_frame = TestFrame(camera, schedule, i, integer);
    ExpectSameConfig(frame.config, want_frame.config);
    EXPECT_EQ(frame.geometry, camera.geometry);
    EXPECT_EQ(frame.saturation_level, 4000.0f);
    EXPECT_TRUE(SameBits(frame.pixels, want_frame.pixels)) << "frame " << i;
  }
  EXPECT_THAT(reader->Read(kFrames, &frame), StatusIs(absl::StatusCode::kOutOfRange,
                                                      HasSubstr("frame 23 is outside 0..22")));
}

INSTANTIATE_TEST_SUITE_P(PixelTypes, CaptureRoundTrip,
                         ::testing::Values(std::pair{CapturePixelType::kFloat32, 0},
                                           std::pair{CapturePixelType::kFloat32, 6},
                                           std::pair{CapturePixelType::kUint16, 0},
                                           std::pair{CapturePixelType::kUint16, 4}));

TEST(CaptureFile, GroundTruthAndCalibrationRoundTrip) {
  ScratchDirectory scratch;
  const std::string path = scratch.File("capture.h5");
  const CameraInfo camera = TestCamera();
  const AcquisitionSchedule schedule = TestSchedule();
  const GroundTruth truth = TestGroundTruth(camera, 3, 2);
  const CalibrationTable calibration = TestCalibration(camera, schedule);
  {
    absl::StatusOr<CaptureWriter> writer =
        CaptureWriter::Create(path, camera, schedule, TestOptions());
    ASSERT_THAT(writer.status(), IsOk());
    ASSERT_THAT(writer->SetGroundTruth(TestGroundTruth(camera, 1, 1)), IsOk());
    ASSERT_THAT(writer->SetGroundTruth(truth), IsOk());  // replaces the first
    ASSERT_THAT(writer->EmbedCalibration(calibration), IsOk());
    ASSERT_THAT(writer->Append(TestFrame(camera, schedule, 0, false)), IsOk());
    EXPECT_THAT(writer->SetGroundTruth(truth),
                StatusIs(absl::StatusCode::kFailedPrecondition, HasSubstr("before the first frame")));
    ASSERT_THAT(writer->Close(), IsOk());
  }
  absl::StatusOr<CaptureReader> reader = CaptureReader::Open(path);
  ASSERT_THAT(reader.status(), IsOk());
  EXPECT_EQ(reader->frames(), 1);
  ASSERT_TRUE(reader->ground_truth().has_value());
  const GroundTruth& got = *reader->ground_truth();
  EXPECT_EQ(got.geometry, camera.geometry);
  EXPECT_EQ(got.max_returns, 3);
  EXPECT_TRUE(SameBits(got.first_range_m, truth.first_range_m));
  EXPECT_TRUE(SameBits(got.return_range_m, truth.return_range_m));
  EXPECT_TRUE(SameBits(got.return_amplitude, truth.return_amplitude));
  EXPECT_TRUE(SameBits(got.return_spread_m, truth.return_spread_m));
  EXPECT_EQ(got.moments.order, 2);
  EXPECT_EQ(got.moments.geometry, camera.geometry);
  EXPECT_TRUE(SameBits(got.moments.real, truth.moments.real));
  EXPECT_TRUE(SameBits(got.moments.imag, truth.moments.imag));
  ASSERT_TRUE(reader->calibration().has_value());
  const CalibrationTable& table = *reader->calibration();
  EXPECT_EQ(table.geometry, calibration.geometry);
  EXPECT_EQ(table.order, calibration.order);
  EXPECT_EQ(table.base_frequency_hz, calibration.base_frequency_hz);
  EXPECT_EQ(table.takes_averaged, calibration.takes_averaged);
  EXPECT_EQ(table.schedule.sampling, calibration.schedule.sampling);
  EXPECT_EQ(table.schedule.zeroth, calibration.schedule.zeroth);
  EXPECT_TRUE(SameBits(table.real, calibration.real));
  EXPECT_TRUE(SameBits(table.imag, calibration.imag));
  EXPECT_EQ(table.valid, calibration.valid);
}

// A capture of TestCamera() and TestSchedule() with uint16 pixels.
absl::StatusOr<CaptureWriter> CreateUint16Capture(const std::string& path) {
  return CaptureWriter::Create(path, TestCamera(), TestSchedule(),
                               TestOptions(CapturePixelType::kUint16));
}

// uint16 pixels are read as stored and widened to float by the reader (not by HDF5): the
// ends of the range and both sides of 2^15 come back exactly, from every frame read.
TEST(CaptureReader, Uint16PixelsComeBackExactlyAcrossTheirWholeRange) {
  ScratchDirectory scratch;
  const CameraInfo camera = TestCamera();
  const AcquisitionSchedule schedule = TestSchedule();
  absl::StatusOr<CaptureWriter> writer = CreateUint16Capture(scratch.File("c.h5"));
  ASSERT_THAT(writer.status(), IsOk());
  constexpr float kEdges[] = {0.0f, 1.0f, 32767.0f, 32768.0f, 65534.0f, 65535.0f};
  std::vector<RawFrame> written;
  for (int64_t i = 0; i < 3; ++i) {
    RawFrame frame = TestFrame(camera, schedule, i, true);
    for (size_t p = 0; p < frame.pixels.size(); ++p) {
      frame.pixels[p] = kEdges[(p + static_cast<size_t>(i)) % std::size(kEdges)];
    }
    ASSERT_THAT(writer->Append(frame), IsOk());
    written.push_back(frame);
  }
  ASSERT_THAT(writer->Close(), IsOk());
  absl::StatusOr<CaptureReader> reader = CaptureReader::Open(scratch.File("c.h5"));
  ASSERT_THAT(reader.status(), IsOk());
  ASSERT_EQ(reader->pixel_type(), CapturePixelType::kUint16);
  RawFrame frame;
  for (int64_t i : {2, 0, 1}) {  // out of order: no state carried from the frame read before
    ASSERT_THAT(reader->Read(i, &frame), IsOk());
    EXPECT_EQ(frame.pixels, written[static_cast<size_t>(i)].pixels) << "frame " << i;
  }
}

TEST(CaptureWriter, RefusesFramesThatDoNotFit) {
  ScratchDirectory scratch;
  const CameraInfo camera = TestCamera();
  const AcquisitionSchedule schedule = TestSchedule();
  absl::StatusOr<CaptureWriter> writer = CreateUint16Capture(scratch.File("c.h5"));
  ASSERT_THAT(writer.status(), IsOk());
  RawFrame frame = TestFrame(camera, schedule, 0, true);
  frame.pixels[3] = 2.5f;
  EXPECT_THAT(writer->Append(frame), StatusIs(absl::StatusCode::kInvalidArgument,
                                              HasSubstr("pixel 3 = 2.5 does not fit")));
  frame.pixels[3] = 70000.0f;
  EXPECT_THAT(writer->Append(frame), StatusIs(absl::StatusCode::kInvalidArgument,
                                              HasSubstr("uint16")));
  frame = TestFrame(TestCamera(8, 5), schedule, 0, true);
  EXPECT_THAT(writer->Append(frame), StatusIs(absl::StatusCode::kInvalidArgument,
                                              HasSubstr("geometry 8x5")));
  frame = TestFrame(camera, schedule, 0, true);
  frame.saturation_level = 1.0f;
  EXPECT_THAT(writer->Append(frame), StatusIs(absl::StatusCode::kInvalidArgument,
                                              HasSubstr("saturation_level = 1")));
  EXPECT_EQ(writer->frames(), 0);
  EXPECT_THAT(writer->SetGroundTruth(TestGroundTruth(TestCamera(3, 3), 1, 2)),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("ground truth geometry")));
  EXPECT_THAT(writer->Close(), IsOk());
  absl::StatusOr<CaptureReader> reader = CaptureReader::Open(scratch.File("c.h5"));
  ASSERT_THAT(reader.status(), IsOk());
  EXPECT_EQ(reader->frames(), 0);
}

TEST(CaptureWriter, RefusesBadOptionsAndExistingFiles) {
  ScratchDirectory scratch;
  CaptureWriterOptions options = TestOptions();
  options.deflate_level = 12;
  EXPECT_THAT(CaptureWriter::Create(scratch.File("a.h5"), TestCamera(), TestSchedule(), options)
                  .status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("deflate_level = 12. Violated constraint")));
  options = TestOptions();
  options.flush_interval = absl::ZeroDuration();
  EXPECT_THAT(CaptureWriter::Create(scratch.File("a.h5"), TestCamera(), TestSchedule(), options)
                  .status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("flush_interval")));
  std::ofstream(scratch.File("exists.h5")) << "x";
  EXPECT_THAT(CaptureWriter::Create(scratch.File("exists.h5"), TestCamera(), TestSchedule(),
                                    TestOptions())
                  .status(),
              StatusIs(absl::StatusCode::kAlreadyExists, HasSubstr("exists.h5: exists")));
  EXPECT_THAT(CaptureWriter::Create(scratch.File("no/such/dir.h5"), TestCamera(), TestSchedule(),
                                    TestOptions())
                  .status(),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("no such directory")));
}

TEST(CaptureWriter, RefusesADepthCamerasScheduleCreatingNothing) {
  ScratchDirectory scratch;
  ScheduleOptions depth;
  depth.sampling = SamplingScheme::kDepth;
  depth.max_depth_m = 8.0;
  depth.depth_amplitude = true;
  absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(depth);
  ASSERT_THAT(schedule.status(), IsOk());
  EXPECT_THAT(
      CaptureWriter::Create(scratch.File("depth.h5"), TestCamera(), *schedule, TestOptions())
          .status(),
      StatusIs(absl::StatusCode::kFailedPrecondition,
               HasSubstr("depth.h5: the source delivers depth, not modulated captures: a capture "
                         "file needs modulated captures (depth camera (Z up to 8 m), with "
                         "amplitude: 2 raw frames)")));
  EXPECT_FALSE(std::filesystem::exists(scratch.File("depth.h5")));
}

// Writes a capture, then lets `edit` change the file with the HDF5 C API.
template <typename Edit>
std::string EditedCapture(const ScratchDirectory& scratch, Edit edit) {
  const std::string path = scratch.File("edited.h5");
  WriteTestCapture(path, 12, TestOptions());
  h5::Id file = h5::File(H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
  EXPECT_TRUE(file.valid());
  edit(file.get());
  return path;
}

void ReplaceDataset(hid_t file, const char* path, hid_t type, std::vector<hsize_t> dims) {
  H5Ldelete(file, path, H5P_DEFAULT);
  h5::Id space = h5::Dataspace(H5Screate_simple(static_cast<int>(dims.size()), dims.data(),
                                                nullptr));
  h5::Id dataset =
      h5::Dataset(H5Dcreate2(file, path, type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  EXPECT_TRUE(dataset.valid());
}

TEST(CaptureReader, RefusesBrokenLayoutsByName) {
  ScratchDirectory scratch;
  struct Case {
    const char* name;
    std::function<void(hid_t)> edit;
    const char* message;
  };
  const std::vector<Case> cases = {
      {"format", [](hid_t f) { ASSERT_TRUE(h5::WriteStringAttribute(f, "format", "transient-capture 2").ok()); },
       "edited.h5: /: attribute format: expected 'transient-capture 1', found 'transient-capture "
       "2' (unsupported major version 2)"},
      {"missing pixels", [](hid_t f) { H5Ldelete(f, "/frames/pixels", H5P_DEFAULT); },
       "edited.h5: /frames/pixels: missing dataset"},
      {"pixels rank", [](hid_t f) { ReplaceDataset(f, "/frames/pixels", H5T_IEEE_F32LE, {12, 35}); },
       "edited.h5: /frames/pixels: expected 3 dimensions [frames, height, width], found 2"},
      {"pixels type", [](hid_t f) { ReplaceDataset(f, "/frames/pixels", H5T_STD_I32LE, {12, 5, 7}); },
       "edited.h5: /frames/pixels: expected uint16 or float32, found int32"},
      {"pixels shape", [](hid_t f) { ReplaceDataset(f, "/frames/pixels", H5T_IEEE_F32LE, {12, 7, 5}); },
       "edited.h5: /frames/pixels: expected shape [height, width] of /camera = [5, 7], found [7, 5]"},
      {"timestamp type", [](hid_t f) { ReplaceDataset(f, "/frames/timestamp_s", H5T_STD_I64LE, {12}); },
       "edited.h5: /frames/timestamp_s: expected float32 or float64, found int64"},
      {"cycle rank", [](hid_t f) { ReplaceDataset(f, "/frames/cycle", H5T_STD_I64LE, {12, 1}); },
       "edited.h5: /frames/cycle: expected 1 dimension [frames], found 2"},
      {"depth schedule", [](hid_t f) {
         h5::Id g = h5::Group(H5Gopen2(f, "/schedule", H5P_DEFAULT));
         ASSERT_TRUE(h5::WriteStringAttribute(g.get(), "sampling", "depth").ok()); },
       "attribute sampling: sampling scheme 'depth' is a depth camera's, which only its source "
       "declares"},
      {"missing camera", [](hid_t f) { H5Ldelete(f, "/camera", H5P_DEFAULT); },
       "edited.h5: /camera: missing group"},
      {"camera width", [](hid_t f) {
         h5::Id g = h5::Group(H5Gopen2(f, "/camera", H5P_DEFAULT));
         ASSERT_TRUE(h5::WriteDoubleAttribute(g.get(), "width", 7.5).ok()); },
       "edited.h5: /camera: attribute width: expected an integer in 1..268435456, found 7.5"},
      {"sampling", [](hid_t f) {
         h5::Id g = h5::Group(H5Gopen2(f, "/schedule", H5P_DEFAULT));
         ASSERT_TRUE(h5::WriteStringAttribute(g.get(), "sampling", "sine").ok()); },
       "edited.h5: /schedule: attribute sampling:"},
      {"raw frames per frame", [](hid_t f) {
         h5::Id g = h5::Group(H5Gopen2(f, "/schedule", H5P_DEFAULT));
         ASSERT_TRUE(h5::WriteInt64Attribute(g.get(), "raw_frames_per_frame", 9).ok()); },
       "edited.h5: /schedule: attribute raw_frames_per_frame: expected 10"},
      {"saturation", [](hid_t f) {
         h5::Id g = h5::Group(H5Gopen2(f, "/frames", H5P_DEFAULT));
         H5Adelete(g.get(), "saturation_level"); },
       "edited.h5: /frames: missing attribute saturation_level"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = EditedCapture(scratch, c.edit);
    EXPECT_THAT(CaptureReader::Open(path).status(),
                StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(c.message)));
    std::filesystem::remove(path);
  }
}

TEST(CaptureReader, ShorterMetadataDatasetLimitsTheFramesWithoutError) {
  ScratchDirectory scratch;
  const std::string path = EditedCapture(scratch, [](hid_t f) {
    h5::Id dataset = h5::Dataset(H5Dopen2(f, "/frames/take", H5P_DEFAULT));
    const hsize_t shorter = 9;
    ASSERT_GE(H5Dset_extent(dataset.get(), &shorter), 0);
  });
  absl::StatusOr<CaptureReader> reader = CaptureReader::Open(path);
  ASSERT_THAT(reader.status(), IsOk());
  EXPECT_EQ(reader->frames(), 9);
}

TEST(CaptureReader, RefusesOtherFormatsByName) {
  ScratchDirectory scratch;
  const std::string moments = scratch.File("moments.h5");
  {
    h5::Id file = h5::File(H5Fcreate(moments.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT));
    ASSERT_TRUE(h5::WriteStringAttribute(file.get(), "format", "transient-moments 1").ok());
  }
  EXPECT_THAT(CaptureReader::Open(moments).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("moments.h5: /: attribute format: expected 'transient-capture "
                                 "1', found 'transient-moments 1' (not a transient-capture file)")));
  const std::string plain = scratch.File("plain.h5");
  { h5::Id file = h5::File(H5Fcreate(plain.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT)); }
  EXPECT_THAT(CaptureReader::Open(plain).status(),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("plain.h5: /: missing attribute format")));
  std::ofstream(scratch.File("text.h5")) << "not hdf5";
  EXPECT_THAT(CaptureReader::Open(scratch.File("text.h5")).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("text.h5: not an HDF5 file")));
  EXPECT_THAT(CaptureReader::Open(scratch.File("none.h5")).status(),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("none.h5: no such file")));
}

}  // namespace
}  // namespace transient
