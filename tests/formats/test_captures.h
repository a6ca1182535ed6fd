// Small known captures for the file and replay tests: a camera, a schedule and raw frames whose
// every pixel and metadata value is a function of its frame index, so reads can be checked
// bit-exactly.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "transient/formats/capture_file.h"
#include "transient/reconstruct/camera_model.h"
#include "transient/reconstruct/ground_truth.h"
#include "transient/reconstruct/acquisition.h"
#include "transient/reconstruct/calibration.h"

namespace transient::testing {

CameraInfo TestCamera(int width = 7, int height = 5);
AcquisitionSchedule TestSchedule();  // four-bucket, m = 2, zeroth pair: 10 raw frames
// Frame `index` of a recording made with TestSchedule: config from the schedule, cycle and
// sequence from the index, timestamps `period_s` apart; integer pixels when `integer`.
RawFrame TestFrame(const CameraInfo& camera, const AcquisitionSchedule& schedule, int64_t index,
                   bool integer, double period_s = 1e-3);
GroundTruth TestGroundTruth(const CameraInfo& camera, int returns, int order);
CalibrationTable TestCalibration(const CameraInfo& camera, const AcquisitionSchedule& schedule);

// Options whose saturation level matches TestFrame's.
CaptureWriterOptions TestOptions(CapturePixelType type = CapturePixelType::kFloat32,
                                 int deflate_level = 0);

// Writes `frames` frames with TestFrame and closes the file.
void WriteTestCapture(const std::string& path, int64_t frames, const CaptureWriterOptions& options,
                      double period_s = 1e-3);

// Overwrites the stored chunk of frame `frame` in the closed capture `path` with `byte`, as a
// bad sector would: the file still opens, that frame's read fails (fails the test if the chunk
// cannot be found; captures store one frame a chunk).
void CorruptFrameChunk(const std::string& path, int64_t frame, char byte);

}  // namespace transient::testing
