// Writer of capture files (layout in capture_file.h): frames appended in HDF5's SWMR mode, so
// that a killed recording stays readable up to its last flush.
#include <cmath>
#include <filesystem>
#include <limits>
#include <utility>

#include "absl/strings/str_cat.h"
#include "calibration_group.h"
#include "capture_layout.h"
#include "ground_truth_group.h"
#include "schedule_attributes.h"
#include "transient/formats/capture_file.h"
#include "transient/formats/format_tag.h"
#include "transient/formats/h5.h"

namespace transient {
namespace {

namespace layout = capture_layout;

// Per-frame datasets are chunked in runs of this many frames: small enough that the chunk
// rewritten at each flush is cheap, large enough that the chunk index stays small.
constexpr hsize_t kMetadataChunk = 256;

h5::Id LatestFormatAccess() {
  // SWMR needs the 1.10 file format (superblock version 3, extensible-array chunk indexes).
  h5::Id access = h5::PropertyList(H5Pcreate(H5P_FILE_ACCESS));
  H5Pset_libver_bounds(access.get(), H5F_LIBVER_LATEST, H5F_LIBVER_LATEST);
  return access;
}

absl::Status CheckCamera(const CameraInfo& camera) {
  const ImageGeometry g = camera.geometry;
  if (g.width < 1 || g.height < 1 || g.pixel_count() > h5::kMaxImagePixels) {
    return absl::InvalidArgumentError(absl::StrCat(
        "camera geometry = ", g.width, "x", g.height,
        ". Violated constraint: width, height >= 1 and width*height <= ", h5::kMaxImagePixels));
  }
  for (double value : {camera.intrinsics.fx, camera.intrinsics.fy, camera.intrinsics.cx,
                       camera.intrinsics.cy, camera.frame_period_s}) {
    if (!std::isfinite(value)) {
      return absl::InvalidArgumentError(
          "camera intrinsics and frame_period_s must be finite numbers");
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status CaptureWriterOptions::Validate() const {
  if (deflate_level < 0 || deflate_level > 9) {
    return absl::InvalidArgumentError(absl::StrCat(
        "deflate_level = ", deflate_level, ". Violated constraint: 0 <= deflate_level <= 9"));
  }
  if (flush_interval <= absl::ZeroDuration() || flush_interval == absl::InfiniteDuration()) {
    return absl::InvalidArgumentError(
        absl::StrCat("flush_interval = ", absl::FormatDuration(flush_interval),
                     ". Violated constraint: 0 < flush_interval < infinity"));
  }
  if (std::isnan(saturation_level)) {
    return absl::InvalidArgumentError(
        "saturation_level = nan. Violated constraint: a number (inf for none)");
  }
  return absl::OkStatus();
}

// ---------------------------------------------------------------------------------------------
// CaptureWriter

absl::StatusOr<CaptureWriter> CaptureWriter::Create(const std::string& path,
                                                    const CameraInfo& camera,
                                                    const AcquisitionSchedule& schedule,
                                                    const CaptureWriterOptions& options) {
  h5::SilenceErrorStack();
  for (absl::Status status : {options.Validate(), CheckCamera(camera)}) {
    if (!status.ok()) return absl::InvalidArgumentError(absl::StrCat(path, ": ", status.message()));
  }
  if (schedule.options().DeliversDepth()) {  // before anything is created
    return absl::FailedPreconditionError(absl::StrCat(
        path, ": ", schedule.options().MissingHarmonicsText("a capture file"), " (",
        schedule.Describe(), ")"));
  }
  std::error_code error;
  if (std::filesystem::exists(path, error)) {
    return absl::AlreadyExistsError(
        absl::StrCat(path, ": exists; a capture is never written over another file"));
  }
  h5::Id access = LatestFormatAccess();
  h5::Id file = h5::File(H5Fcreate(path.c_str(), H5F_ACC_EXCL, H5P_DEFAULT, access.get()));
  if (!file.valid()) {
    const std::filesystem::path parent = std::filesystem::path(path).parent_path();
    if (!parent.empty() && !std::filesystem::is_directory(parent, error)) {
      return absl::NotFoundError(absl::StrCat(path, ": no such directory ", parent.string()));
    }
    return absl::PermissionDeniedError(absl::StrCat(path, ": HDF5 cannot create the file"));
  }
  const auto failed = [&](absl::string_view what) {
    file = h5::Id();
    std::filesystem::remove(path, error);
    return absl::InternalError(absl::StrCat(path, ": cannot write ", what));
  };
  const hid_t root = file.get();
  absl::Status status = WriteFormatAttribute(root, kCaptureFormatName, kCaptureFormatMajor);
  status.Update(h5::WriteStringAttribute(root, "source_uri", options.source_uri));
  if (!status.ok()) return failed("the root attributes");

  h5::Id camera_group =
      h5::Group(H5Gcreate2(root, layout::kCameraGroup, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!camera_group.valid()) return failed(layout::kCameraGroup);
  const hid_t cg = camera_group.get();
  status.Update(h5::WriteInt64Attribute(cg, "width", camera.geometry.width));
  status.Update(h5::WriteInt64Attribute(cg, "height", camera.geometry.height));
  status.Update(h5::WriteDoubleAttribute(cg, "fx", camera.intrinsics.fx));
  status.Update(h5::WriteDoubleAttribute(cg, "fy", camera.intrinsics.fy));
  status.Update(h5::WriteDoubleAttribute(cg, "cx", camera.intrinsics.cx));
  status.Update(h5::WriteDoubleAttribute(cg, "cy", camera.intrinsics.cy));
  status.Update(h5::WriteDoubleArrayAttribute(
      cg, "distortion", {camera.distortion.begin(), camera.distortion.end()}));
  status.Update(h5::WriteStringAttribute(cg, "model", camera.model));
  status.Update(h5::WriteDoubleAttribute(cg, "frame_period_s", camera.frame_period_s));
  if (!status.ok()) return failed(layout::kCameraGroup);

  const ScheduleOptions& s = schedule.options();
  h5::Id schedule_group =
      h5::Group(H5Gcreate2(root, layout::kScheduleGroup, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!schedule_group.valid()) return failed(layout::kScheduleGroup);
  const hid_t sg = schedule_group.get();
  status.Update(WriteScheduleAttributes(sg, s));
  status.Update(
      h5::WriteInt64Attribute(sg, "raw_frames_per_frame", schedule.raw_frames_per_frame()));
  if (!status.ok()) return failed(layout::kScheduleGroup);

  h5::Id frames =
      h5::Group(H5Gcreate2(root, layout::kFramesGroup, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!frames.valid()) return failed(layout::kFramesGroup);
  if (!h5::WriteDoubleAttribute(frames.get(), "saturation_level", options.saturation_level).ok()) {
    return failed(layout::kFramesGroup);
  }
  const hsize_t h = camera.geometry.height, w = camera.geometry.width;
  const hid_t pixel_type =
      options.pixel_type == CapturePixelType::kUint16 ? H5T_STD_U16LE : H5T_IEEE_F32LE;
  if (!h5::CreateDataset(frames.get(), "pixels", pixel_type,
                         {.dims = {0, h, w},
                          .max_dims = {H5S_UNLIMITED, h, w},
                          .chunk = {1, h, w},
                          .deflate_level = options.deflate_level})
           .ok()) {
    return failed(layout::kPixelsPath);
  }
  for (const layout::FieldSpec& spec : layout::kFields) {
    const layout::FieldStorage storage = layout::StorageOf(spec.field);
    if (!h5::CreateDataset(frames.get(), spec.name, storage.file_type,
                           {.dims = {0},
                            .max_dims = {H5S_UNLIMITED},
                            .chunk = {kMetadataChunk},
                            .fill_type = storage.memory_type,
                            .fill = &storage.fill})
             .ok()) {
      return failed(layout::FramesObject(spec.name));
    }
  }
  frames = h5::Id();
  schedule_group = h5::Id();
  camera_group = h5::Id();
  if (!file.Close().ok()) return failed("the file (closing failed)");

  CaptureWriter writer;
  writer.path_ = path;
  writer.camera_ = camera;
  writer.options_ = options;
  return writer;
}

CaptureWriter::~CaptureWriter() {
  if (!path_.empty()) Close().IgnoreError();
}

absl::Status CaptureWriter::OpenForFrames() {
  h5::Id access = LatestFormatAccess();
  // Opening straight into SWMR mode sets both of the superblock's marks in one write, so a
  // crash at any later moment leaves a file that SWMR readers accept.
  file_ = h5::File(H5Fopen(path_.c_str(), H5F_ACC_RDWR | H5F_ACC_SWMR_WRITE, access.get()));
  if (!file_.valid()) {
    return absl::InternalError(absl::StrCat(path_, ": cannot reopen the capture for writing"));
  }
  pixels_ = h5::Dataset(H5Dopen2(file_.get(), layout::kPixelsPath, H5P_DEFAULT));
  if (!pixels_.valid())
    return absl::InternalError(absl::StrCat(path_, ": cannot open ", layout::kPixelsPath));
  metadata_.clear();
  for (const layout::FieldSpec& spec : layout::kFields) {
    metadata_.push_back(
        h5::Dataset(H5Dopen2(file_.get(), layout::FramesObject(spec.name).c_str(), H5P_DEFAULT)));
    if (!metadata_.back().valid()) {
      return absl::InternalError(
          absl::StrCat(path_, ": cannot open ", layout::FramesObject(spec.name)));
    }
  }
  last_flush_ = absl::Now();
  return absl::OkStatus();
}

absl::Status CaptureWriter::CheckFrame(const RawFrame& frame) const {
  const std::string where = absl::StrCat(path_, ": frame ", frames_);
  if (!(frame.geometry == camera_.geometry) ||
      frame.pixels.size() != static_cast<size_t>(camera_.geometry.pixel_count())) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": geometry ", frame.geometry.width, "x", frame.geometry.height,
                     " with ", frame.pixels.size(), " pixels, expected the camera's ",
                     camera_.geometry.width, "x", camera_.geometry.height));
  }
  if (!(frame.saturation_level == options_.saturation_level)) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": saturation_level = ", frame.saturation_level,
                     ", expected the capture's ", options_.saturation_level));
  }
  const ExposureConfig& c = frame.config;
  if (!std::isfinite(c.frequency_hz) || !std::isfinite(c.phase_shift_rad) ||
      !std::isfinite(c.exposure_s) || !std::isfinite(c.timestamp_s) || c.harmonic < 0 ||
      c.take < 0 || c.cycle < 0 || c.sequence == std::numeric_limits<uint64_t>::max()) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": metadata (", DescribeExposure(c), ", cycle ", c.cycle, ", sequence ",
                     c.sequence, ", timestamp ", c.timestamp_s,
                     " s) must be finite, harmonic, take and cycle >= 0 and sequence < 2^64-1"));
  }
  if (options_.pixel_type == CapturePixelType::kUint16) {
    for (size_t i = 0; i < frame.pixels.size(); ++i) {
      const float v = frame.pixels[i];
      if (!(v >= 0.0f && v <= 65535.0f) || std::floor(v) != v) {
        return absl::InvalidArgumentError(absl::StrCat(
            where, ": pixel ", i, " = ", v,
            " does not fit the capture's uint16 pixels (integers 0..65535); record float32"));
      }
    }
  }
  return absl::OkStatus();
}

absl::Status CaptureWriter::Append(const RawFrame& frame) {
  if (closed_) return absl::FailedPreconditionError(absl::StrCat(path_, ": closed"));
  if (absl::Status status = CheckFrame(frame); !status.ok()) return status;
  if (!file_.valid()) {
    if (absl::Status status = OpenForFrames(); !status.ok()) return status;
  }
  const hsize_t index = static_cast<hsize_t>(frames_);
  const ExposureConfig& c = frame.config;
  const auto write_failed = [&](absl::string_view object) {
    return absl::InternalError(
        absl::StrCat(path_, ": ", object, ": cannot write frame ", frames_, " (disk full?)"));
  };
  // Pixels before metadata: a reader counts a frame only once both are there.
  if (!h5::AppendAlongFirst(pixels_.get(), index, H5T_NATIVE_FLOAT, frame.pixels.data()).ok()) {
    return write_failed(layout::kPixelsPath);
  }
  for (int f = 0; f < layout::kFieldCount; ++f) {
    const layout::FieldSpec& spec = layout::kFields[f];
    const layout::FieldValue value = layout::ValueOf(spec.field, c);
    const void* data = spec.integer ? static_cast<const void*>(&value.integer) : &value.real;
    if (!h5::AppendAlongFirst(metadata_[f].get(), index, layout::ExchangeType(spec.field), data)
             .ok()) {
      return write_failed(layout::FramesObject(spec.name));
    }
  }
  ++frames_;
  if (absl::Now() - last_flush_ >= options_.flush_interval) return Flush();
  return absl::OkStatus();
}

absl::Status CaptureWriter::Flush() {
  if (closed_) return absl::FailedPreconditionError(absl::StrCat(path_, ": closed"));
  if (!file_.valid()) {
    if (absl::Status status = OpenForFrames(); !status.ok()) return status;
  }
  // In SWMR mode HDF5 writes raw data before the metadata that points at it, and parents after
  // children, so the file on disk is consistent at every instant of the flush too.
  if (H5Fflush(file_.get(), H5F_SCOPE_GLOBAL) < 0) {
    return absl::InternalError(absl::StrCat(path_, ": flush failed (disk full?)"));
  }
  flushed_ = frames_;
  last_flush_ = absl::Now();
  return absl::OkStatus();
}

absl::Status CaptureWriter::Close() {
  if (closed_ || path_.empty()) return absl::OkStatus();
  closed_ = true;
  absl::Status status;
  if (file_.valid()) {
    if (H5Fflush(file_.get(), H5F_SCOPE_GLOBAL) < 0) {
      status = absl::InternalError(absl::StrCat(path_, ": flush failed (disk full?)"));
    } else {
      flushed_ = frames_;
    }
    metadata_.clear();
    pixels_ = h5::Id();
    if (!file_.Close().ok() && status.ok()) {
      status = absl::InternalError(absl::StrCat(path_, ": closing failed (disk full?)"));
    }
    // What was flushed before the failure stays readable (h5::ExtendToRecordedEnd).
    if (!status.ok()) (void)h5::ExtendToRecordedEnd(path_);
  }
  return status;
}

absl::Status CaptureWriter::WriteGroup(const char* name, const GroundTruth* truth,
                                       const CalibrationTable* calibration) {
  if (closed_) return absl::FailedPreconditionError(absl::StrCat(path_, ": closed"));
  if (file_.valid()) {
    return absl::FailedPreconditionError(
        absl::StrCat(path_, ": ", name,
                     " can only be added before the first frame (HDF5 1.10 cannot add "
                     "objects to a file in SWMR mode)"));
  }
  h5::Id access = LatestFormatAccess();
  h5::Id file = h5::File(H5Fopen(path_.c_str(), H5F_ACC_RDWR, access.get()));
  if (!file.valid()) return absl::InternalError(absl::StrCat(path_, ": cannot reopen the capture"));
  if (H5Lexists(file.get(), name, H5P_DEFAULT) > 0) H5Ldelete(file.get(), name, H5P_DEFAULT);
  h5::Id group = h5::Group(H5Gcreate2(file.get(), name, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!group.valid()) return absl::InternalError(absl::StrCat(path_, ": cannot create ", name));
  absl::Status status = truth != nullptr ? WriteGroundTruthGroup(group.get(), *truth)
                                         : WriteCalibrationGroup(group.get(), *calibration);
  if (!status.ok()) {
    return absl::InternalError(absl::StrCat(path_, ": ", name, ": ", status.message()));
  }
  group = h5::Id();
  if (!file.Close().ok()) return absl::InternalError(absl::StrCat(path_, ": closing failed"));
  return absl::OkStatus();
}

absl::Status CaptureWriter::SetGroundTruth(const GroundTruth& truth) {
  if (absl::Status status = CheckGroundTruth(truth, camera_.geometry); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(path_, ": ", status.message()));
  }
  return WriteGroup(layout::kGroundTruthGroup, &truth, nullptr);
}

absl::Status CaptureWriter::EmbedCalibration(const CalibrationTable& calibration) {
  if (absl::Status status = CheckCalibrationTable(calibration); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(path_, ": ", status.message()));
  }
  return WriteGroup(layout::kCalibrationGroup, nullptr, &calibration);
}

}  // namespace transient
