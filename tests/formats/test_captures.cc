// Known captures for the file and replay tests.
#include "tests/formats/test_captures.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "transient/formats/h5.h"

namespace transient::testing {

CameraInfo TestCamera(int width, int height) {
  CameraInfo camera;
  camera.geometry = {.width = width, .height = height};
  camera.intrinsics = {.fx = 101.5, .fy = 102.25, .cx = 3.5, .cy = 2.25};
  camera.distortion = {0.1, -0.02, 0.001, -0.003, 0.0004};
  camera.model = "test camera";
  camera.frame_period_s = 1e-3;
  return camera;
}

AcquisitionSchedule TestSchedule() {
  ScheduleOptions options;
  options.base_frequency_hz = 20e6;
  options.order = 2;
  options.sampling = SamplingScheme::kFourBucket;
  options.phase_steps = 1;
  options.zeroth = ZerothScheme::kUnmodulatedPair;
  options.exposure_s = 1e-3;
  options.takes = 1;
  absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(options);
  EXPECT_TRUE(schedule.ok()) << schedule.status();
  return *schedule;
}

RawFrame TestFrame(const CameraInfo& camera, const AcquisitionSchedule& schedule, int64_t index,
                   bool integer, double period_s) {
  const int per_cycle = schedule.raw_frames_per_frame();
  RawFrame frame;
  frame.config = schedule.exposures()[index % per_cycle];
  frame.config.cycle = index / per_cycle;
  frame.config.sequence = static_cast<uint64_t>(index) + 1000;
  frame.config.timestamp_s = static_cast<double>(index) * period_s;
  frame.geometry = camera.geometry;
  frame.pixels.resize(camera.geometry.pixel_count());
  for (size_t p = 0; p < frame.pixels.size(); ++p) {
    const int64_t value = (index * 131 + static_cast<int64_t>(p) * 7) % 65536;
    frame.pixels[p] = integer ? static_cast<float>(value)
                              : static_cast<float>(value) * 0.37f - 1000.0f;
  }
  if (!integer && !frame.pixels.empty()) frame.pixels[0] = std::nanf("");
  frame.saturation_level = 4000.0f;
  return frame;
}

GroundTruth TestGroundTruth(const CameraInfo& camera, int returns, int order) {
  GroundTruth truth;
  truth.geometry = camera.geometry;
  truth.max_returns = returns;
  const int64_t pixels = camera.geometry.pixel_count();
  for (int64_t p = 0; p < pixels; ++p) truth.first_range_m.push_back(1.0f + 0.01f * p);
  for (int64_t i = 0; i < returns * pixels; ++i) {
    truth.return_range_m.push_back(2.0f + 0.5f * i);
    truth.return_amplitude.push_back(100.0f - i);
    truth.return_spread_m.push_back(i % 3 == 0 ? 0.0f : std::nanf(""));
  }
  truth.moments.geometry = camera.geometry;
  truth.moments.order = order;
  for (int64_t i = 0; i < (order + 1) * pixels; ++i) {
    truth.moments.real.push_back(0.25f * i);
    truth.moments.imag.push_back(-0.5f * i);
  }
  return truth;
}

CalibrationTable TestCalibration(const CameraInfo& camera, const AcquisitionSchedule& schedule) {
  CalibrationTable table;
  table.geometry = camera.geometry;
  table.order = schedule.order();
  table.base_frequency_hz = schedule.options().base_frequency_hz;
  table.schedule = schedule.options();
  table.takes_averaged = 16;
  const int64_t pixels = camera.geometry.pixel_count();
  for (int64_t i = 0; i < (table.order + 1) * pixels; ++i) {
    table.real.push_back(1.0f + 0.001f * i);
    table.imag.push_back(-0.002f * i);
  }
  for (int64_t p = 0; p < pixels; ++p) table.valid.push_back(p % 5 == 0 ? 0 : 1);
  table.real[0] = std::nanf("");
  return table;
}

CaptureWriterOptions TestOptions(CapturePixelType type, int deflate_level) {
  CaptureWriterOptions options;
  options.pixel_type = type;
  options.deflate_level = deflate_level;
  options.source_uri = "sim:test?m=2";
  options.saturation_level = 4000.0f;
  return options;
}

void WriteTestCapture(const std::string& path, int64_t frames, const CaptureWriterOptions& options,
                      double period_s) {
  const CameraInfo camera = TestCamera();
  const AcquisitionSchedule schedule = TestSchedule();
  absl::StatusOr<CaptureWriter> writer = CaptureWriter::Create(path, camera, schedule, options);
  ASSERT_TRUE(writer.ok()) << writer.status();
  const bool integer = options.pixel_type == CapturePixelType::kUint16;
  for (int64_t i = 0; i < frames; ++i) {
    ASSERT_TRUE(writer->Append(TestFrame(camera, schedule, i, integer, period_s)).ok());
  }
  ASSERT_TRUE(writer->Close().ok());
}

void CorruptFrameChunk(const std::string& path, int64_t frame, char byte) {
  haddr_t address = HADDR_UNDEF;
  hsize_t size = 0;
  {
    h5::Id file = h5::File(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
    h5::Id pixels = h5::Dataset(H5Dopen2(file.get(), "/frames/pixels", H5P_DEFAULT));
    const hsize_t offset[3] = {static_cast<hsize_t>(frame), 0, 0};
    unsigned mask = 0;
    ASSERT_GE(H5Dget_chunk_info_by_coord(pixels.get(), offset, &mask, &address, &size), 0)
        << path << " frame " << frame;
  }
  std::fstream stream(path, std::ios::in | std::ios::out | std::ios::binary);
  stream.seekp(static_cast<std::streamoff>(address));
  const std::string garbage(size, byte);
  stream.write(garbage.data(), static_cast<std::streamsize>(garbage.size()));
  ASSERT_TRUE(stream.good()) << "writing " << path;
}

}  // namespace transient::testing
