// Capture files (layout in capture_file.h): a writer that appends frames in HDF5's SWMR mode so
// that a killed recording stays readable, and a reader that checks the whole layout and counts
// only the frames that were completely written.
#include "transient/formats/capture_file.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <utility>

#include "absl/strings/str_cat.h"
#include "layout.h"
#include "transient/formats/format_tag.h"
#include "transient/reconstruct/moments.h"

namespace transient {
namespace {

using internal::Where;

constexpr char kFramesGroup[] = "/frames";
constexpr char kPixelsPath[] = "/frames/pixels";
constexpr char kGroundTruthGroup[] = "ground_truth";
constexpr char kCalibrationGroup[] = "calibration";
// Per-frame datasets are chunked in runs of this many frames: small enough that the chunk
// rewritten at each flush is cheap, large enough that the chunk index stays small.
constexpr hsize_t kMetadataChunk = 256;
constexpr unsigned kSwmrReadAttempts = 4;

// One per-frame dataset: its name, its file type, and the fill value that marks an entry
// that was never written (no frame can hold it).
enum class Field { kHarmonic, kFrequency, kPhaseShift, kExposure, kIllumination, kTake, kCycle,
                   kSequence, kTimestamp };
constexpr int kFieldCount = 9;
struct FieldSpec {
  Field field;
  const char* name;
  bool integer;
};
constexpr FieldSpec kFields[kFieldCount] = {
    {Field::kHarmonic, "harmonic", true},         {Field::kFrequency, "frequency_hz", false},
    {Field::kPhaseShift, "phase_shift_rad", false}, {Field::kExposure, "exposure_s", false},
    {Field::kIllumination, "illumination", true}, {Field::kTake, "take", true},
    {Field::kCycle, "cycle", true},               {Field::kSequence, "sequence", true},
    {Field::kTimestamp, "timestamp_s", false},
};

// File type, and the memory type and fill value the writer uses for it.
struct FieldStorage {
  hid_t file_type;
  hid_t memory_type;
  union {
    int32_t i32;
    int64_t i64;
    uint64_t u64;
    uint8_t u8;
    double f64;
  } fill;
};

FieldStorage StorageOf(Field field) {
  FieldStorage storage{};
  switch (field) {
    case Field::kHarmonic:
    case Field::kTake:
      storage = {H5T_STD_I32LE, H5T_NATIVE_INT32, {}};
      storage.fill.i32 = -1;
      break;
    case Field::kCycle:
      storage = {H5T_STD_I64LE, H5T_NATIVE_INT64, {}};
      storage.fill.i64 = -1;
      break;
    case Field::kSequence:
      storage = {H5T_STD_U64LE, H5T_NATIVE_UINT64, {}};
      storage.fill.u64 = std::numeric_limits<uint64_t>::max();
      break;
    case Field::kIllumination:
      storage = {H5T_STD_U8LE, H5T_NATIVE_UINT8, {}};
      storage.fill.u8 = 255;
      break;
    case Field::kFrequency:
    case Field::kPhaseShift:
    case Field::kExposure:
    case Field::kTimestamp:
      storage = {H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {}};
      storage.fill.f64 = std::numeric_limits<double>::quiet_NaN();
      break;
  }
  return storage;
}

h5::Id LatestFormatAccess() {
  // SWMR needs the 1.10 file format (superblock version 3, extensible-array chunk indexes).
  h5::Id access = h5::PropertyList(H5Pcreate(H5P_FILE_ACCESS));
  H5Pset_libver_bounds(access.get(), H5F_LIBVER_LATEST, H5F_LIBVER_LATEST);
  return access;
}

std::string FramesObject(const char* name) { return absl::StrCat(kFramesGroup, "/", name); }

// Appends one element (or one [1, H, W] plane) at `index` of an extendible dataset.
absl::Status AppendAt(hid_t dataset, hsize_t index, const std::vector<hsize_t>& plane,
                      hid_t memory_type, const void* data) {
  std::vector<hsize_t> extent = plane;
  extent[0] = index + 1;
  std::vector<hsize_t> start(plane.size(), 0);
  start[0] = index;
  if (H5Dset_extent(dataset, extent.data()) < 0) return absl::InternalError("extent");
  h5::Id file_space = h5::Dataspace(H5Dget_space(dataset));
  h5::Id memory_space =
      h5::Dataspace(H5Screate_simple(static_cast<int>(plane.size()), plane.data(), nullptr));
  if (H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start.data(), nullptr, plane.data(),
                          nullptr) < 0 ||
      H5Dwrite(dataset, memory_type, memory_space.get(), file_space.get(), H5P_DEFAULT, data) < 0) {
    return absl::InternalError("write");
  }
  return absl::OkStatus();
}

absl::Status CheckCamera(const CameraInfo& camera) {
  const ImageGeometry g = camera.geometry;
  if (g.width < 1 || g.height < 1 || g.pixel_count() > internal::kMaxFilePixels) {
    return absl::InvalidArgumentError(
        absl::StrCat("camera geometry = ", g.width, "x", g.height,
                     ". Violated constraint: width, height >= 1 and width*height <= ",
                     internal::kMaxFilePixels));
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

absl::Status CheckGroundTruth(const GroundTruth& truth, ImageGeometry camera) {
  const size_t pixels = static_cast<size_t>(camera.pixel_count());
  const size_t returns = static_cast<size_t>(std::max(truth.max_returns, 0)) * pixels;
  const int m = truth.moments.order;
  const size_t moments = static_cast<size_t>(m + 1) * pixels;
  if (!(truth.geometry == camera) || !(truth.moments.geometry == camera)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "ground truth geometry = ", truth.geometry.width, "x", truth.geometry.height,
        ", moments ", truth.moments.geometry.width, "x", truth.moments.geometry.height,
        ". Violated constraint: both are the camera's ", camera.width, "x", camera.height));
  }
  if (truth.max_returns < 0 || m < 1 || m > kMaxOrder || truth.first_range_m.size() != pixels ||
      truth.return_range_m.size() != returns || truth.return_amplitude.size() != returns ||
      truth.return_spread_m.size() != returns || truth.moments.real.size() != moments ||
      truth.moments.imag.size() != moments) {
    return absl::InvalidArgumentError(absl::StrCat(
        "ground truth max_returns = ", truth.max_returns, ", order = ", m,
        ". Violated constraint: max_returns >= 0, 1 <= order <= ", kMaxOrder,
        ", first_range_m holds H*W values, return_* R*H*W, moments (m+1)*H*W"));
  }
  return absl::OkStatus();
}

absl::Status WriteGroundTruthGroup(hid_t group, const GroundTruth& truth) {
  const hsize_t h = truth.geometry.height, w = truth.geometry.width;
  const hsize_t r = truth.max_returns, m1 = truth.moments.order + 1;
  absl::Status status = internal::WriteDataset(group, "first_range_m", H5T_IEEE_F32LE,
                                               H5T_NATIVE_FLOAT, {h, w},
                                               truth.first_range_m.data());
  for (auto [name, data] : {std::pair{"return_range_m", &truth.return_range_m},
                            std::pair{"return_amplitude", &truth.return_amplitude},
                            std::pair{"return_spread_m", &truth.return_spread_m}}) {
    status.Update(internal::WriteDataset(group, name, H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, {r, h, w},
                                         data->data()));
  }
  if (!status.ok()) return status;
  h5::Id moments = h5::Group(H5Gcreate2(group, "moments", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!moments.valid()) return absl::InternalError("cannot create group moments");
  status.Update(internal::WriteDataset(moments.get(), "real", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT,
                                       {m1, h, w}, truth.moments.real.data()));
  status.Update(internal::WriteDataset(moments.get(), "imag", H5T_IEEE_F32LE, H5T_NATIVE_FLOAT,
                                       {m1, h, w}, truth.moments.imag.data()));
  return status;
}

absl::StatusOr<GroundTruth> ReadGroundTruthGroup(hid_t file, const std::string& path,
                                                 ImageGeometry camera) {
  GroundTruth truth;
  truth.geometry = camera;
  const hsize_t h = camera.height, w = camera.width;
  std::vector<hsize_t> dims;
  const auto read_plane = [&](const std::string& object, const std::vector<hsize_t>& expected,
                              const char* description, std::vector<float>* out) -> absl::Status {
    absl::StatusOr<h5::Id> dataset =
        internal::OpenDataset(file, path, object, internal::kAnyFloat,
                              static_cast<int>(expected.size()), description, &dims);
    if (!dataset.ok()) return dataset.status();
    if (absl::Status status = internal::CheckShape(Where(path, object), dims, expected, description);
        !status.ok()) {
      return status;
    }
    size_t count = 1;
    for (hsize_t d : dims) count *= d;
    out->resize(count);
    return internal::ReadDataset(dataset->get(), H5T_NATIVE_FLOAT, out->data(), Where(path, object));
  };
  if (absl::Status status =
          read_plane("/ground_truth/first_range_m", {h, w}, "[height, width]", &truth.first_range_m);
      !status.ok()) {
    return status;
  }
  // R comes from return_range_m; the other two must agree with it.
  {
    absl::StatusOr<h5::Id> probe =
        internal::OpenDataset(file, path, "/ground_truth/return_range_m", internal::kAnyFloat, 3,
                              "[returns, height, width]", &dims);
    if (!probe.ok()) return probe.status();
    truth.max_returns = static_cast<int>(std::min<hsize_t>(dims[0], 1 << 20));
  }
  const hsize_t r = truth.max_returns;
  for (auto [object, out] :
       {std::pair{"/ground_truth/return_range_m", &truth.return_range_m},
        std::pair{"/ground_truth/return_amplitude", &truth.return_amplitude},
        std::pair{"/ground_truth/return_spread_m", &truth.return_spread_m}}) {
    if (absl::Status status = read_plane(object, {r, h, w}, "[returns, height, width]", out);
        !status.ok()) {
      return status;
    }
  }
  {
    absl::StatusOr<h5::Id> probe =
        internal::OpenDataset(file, path, "/ground_truth/moments/real", internal::kAnyFloat, 3,
                              "[m+1, height, width]", &dims);
    if (!probe.ok()) return probe.status();
    if (dims[0] < 2 || dims[0] > static_cast<hsize_t>(kMaxMoments)) {
      return absl::InvalidArgumentError(
          absl::StrCat(Where(path, "/ground_truth/moments/real"), ": expected m+1 = 2..",
                       kMaxMoments, " moments in dimension 1, found ", dims[0]));
    }
  }
  const hsize_t m1 = dims[0];
  truth.moments.geometry = camera;
  truth.moments.order = static_cast<int>(m1) - 1;
  for (auto [object, out] : {std::pair{"/ground_truth/moments/real", &truth.moments.real},
                             std::pair{"/ground_truth/moments/imag", &truth.moments.imag}}) {
    if (absl::Status status = read_plane(object, {m1, h, w}, "[m+1, height, width]", out);
        !status.ok()) {
      return status;
    }
  }
  return truth;
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
  absl::Status status = h5::WriteStringAttribute(
      root, "format", FormatTagString(kCaptureFormatName, kCaptureFormatMajor));
  status.Update(h5::WriteStringAttribute(root, "source_uri", options.source_uri));
  if (!status.ok()) return failed("the root attributes");

  h5::Id camera_group = h5::Group(H5Gcreate2(root, "camera", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!camera_group.valid()) return failed("/camera");
  const hid_t cg = camera_group.get();
  status.Update(h5::WriteInt64Attribute(cg, "width", camera.geometry.width));
  status.Update(h5::WriteInt64Attribute(cg, "height", camera.geometry.height));
  status.Update(h5::WriteDoubleAttribute(cg, "fx", camera.intrinsics.fx));
  status.Update(h5::WriteDoubleAttribute(cg, "fy", camera.intrinsics.fy));
  status.Update(h5::WriteDoubleAttribute(cg, "cx", camera.intrinsics.cx));
  status.Update(h5::WriteDoubleAttribute(cg, "cy", camera.intrinsics.cy));
  status.Update(internal::WriteDoubleArrayAttribute(
      cg, "distortion", {camera.distortion.begin(), camera.distortion.end()}));
  status.Update(h5::WriteStringAttribute(cg, "model", camera.model));
  status.Update(h5::WriteDoubleAttribute(cg, "frame_period_s", camera.frame_period_s));
  if (!status.ok()) return failed("/camera");

  const ScheduleOptions& s = schedule.options();
  h5::Id schedule_group =
      h5::Group(H5Gcreate2(root, "schedule", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!schedule_group.valid()) return failed("/schedule");
  const hid_t sg = schedule_group.get();
  status.Update(h5::WriteDoubleAttribute(sg, "base_frequency_hz", s.base_frequency_hz));
  status.Update(h5::WriteInt64Attribute(sg, "order", s.order));
  status.Update(h5::WriteStringAttribute(sg, "sampling", SamplingSchemeName(s.sampling)));
  status.Update(h5::WriteInt64Attribute(sg, "phase_steps", s.phase_steps));
  status.Update(h5::WriteStringAttribute(sg, "zeroth", ZerothSchemeName(s.zeroth)));
  status.Update(h5::WriteDoubleAttribute(sg, "proxy_frequency_hz", s.proxy_frequency_hz));
  status.Update(h5::WriteDoubleAttribute(sg, "exposure_s", s.exposure_s));
  status.Update(h5::WriteInt64Attribute(sg, "takes", s.takes));
  status.Update(h5::WriteInt64Attribute(sg, "raw_frames_per_frame", schedule.raw_frames_per_frame()));
  if (!status.ok()) return failed("/schedule");

  h5::Id frames = h5::Group(H5Gcreate2(root, "frames", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!frames.valid()) return failed("/frames");
  if (!h5::WriteDoubleAttribute(frames.get(), "saturation_level", options.saturation_level).ok()) {
    return failed("/frames");
  }
  {
    const hsize_t h = camera.geometry.height, w = camera.geometry.width;
    const hsize_t dims[3] = {0, h, w}, max_dims[3] = {H5S_UNLIMITED, h, w}, chunk[3] = {1, h, w};
    h5::Id space = h5::Dataspace(H5Screate_simple(3, dims, max_dims));
    h5::Id creation = h5::PropertyList(H5Pcreate(H5P_DATASET_CREATE));
    H5Pset_chunk(creation.get(), 3, chunk);
    if (options.deflate_level > 0) {
      H5Pset_shuffle(creation.get());
      H5Pset_deflate(creation.get(), options.deflate_level);
    }
    const hid_t type =
        options.pixel_type == CapturePixelType::kUint16 ? H5T_STD_U16LE : H5T_IEEE_F32LE;
    h5::Id pixels = h5::Dataset(H5Dcreate2(frames.get(), "pixels", type, space.get(), H5P_DEFAULT,
                                           creation.get(), H5P_DEFAULT));
    if (!pixels.valid()) return failed(kPixelsPath);
  }
  for (const FieldSpec& spec : kFields) {
    const FieldStorage storage = StorageOf(spec.field);
    const hsize_t dims = 0, max_dims = H5S_UNLIMITED;
    h5::Id space = h5::Dataspace(H5Screate_simple(1, &dims, &max_dims));
    h5::Id creation = h5::PropertyList(H5Pcreate(H5P_DATASET_CREATE));
    H5Pset_chunk(creation.get(), 1, &kMetadataChunk);
    H5Pset_fill_value(creation.get(), storage.memory_type, &storage.fill);
    h5::Id dataset = h5::Dataset(H5Dcreate2(frames.get(), spec.name, storage.file_type,
                                            space.get(), H5P_DEFAULT, creation.get(), H5P_DEFAULT));
    if (!dataset.valid()) return failed(FramesObject(spec.name));
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
  file_ = h5::File(
      H5Fopen(path_.c_str(), H5F_ACC_RDWR | H5F_ACC_SWMR_WRITE, access.get()));
  if (!file_.valid()) {
    return absl::InternalError(absl::StrCat(path_, ": cannot reopen the capture for writing"));
  }
  pixels_ = h5::Dataset(H5Dopen2(file_.get(), kPixelsPath, H5P_DEFAULT));
  if (!pixels_.valid()) return absl::InternalError(absl::StrCat(path_, ": cannot open ", kPixelsPath));
  metadata_.clear();
  for (const FieldSpec& spec : kFields) {
    metadata_.push_back(h5::Dataset(H5Dopen2(file_.get(), FramesObject(spec.name).c_str(),
                                             H5P_DEFAULT)));
    if (!metadata_.back().valid()) {
      return absl::InternalError(absl::StrCat(path_, ": cannot open ", FramesObject(spec.name)));
    }
  }
  last_flush_ = absl::Now();
  return absl::OkStatus();
}

absl::Status CaptureWriter::CheckFrame(const RawFrame& frame) const {
  const std::string where = absl::StrCat(path_, ": frame ", frames_);
  if (!(frame.geometry == camera_.geometry) ||
      frame.pixels.size() != static_cast<size_t>(camera_.geometry.pixel_count())) {
    return absl::InvalidArgumentError(absl::StrCat(
        where, ": geometry ", frame.geometry.width, "x", frame.geometry.height, " with ",
        frame.pixels.size(), " pixels, expected the camera's ", camera_.geometry.width, "x",
        camera_.geometry.height));
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
    return absl::InvalidArgumentError(absl::StrCat(
        where, ": metadata (", DescribeExposure(c), ", cycle ", c.cycle, ", sequence ",
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
  const hsize_t plane[3] = {1, static_cast<hsize_t>(camera_.geometry.height),
                            static_cast<hsize_t>(camera_.geometry.width)};
  if (!AppendAt(pixels_.get(), index, {plane, plane + 3}, H5T_NATIVE_FLOAT, frame.pixels.data())
           .ok()) {
    return write_failed(kPixelsPath);
  }
  for (int f = 0; f < kFieldCount; ++f) {
    const FieldStorage storage = StorageOf(kFields[f].field);
    int32_t i32 = 0;
    int64_t i64 = 0;
    uint64_t u64 = 0;
    uint8_t u8 = 0;
    double f64 = 0;
    const void* value = nullptr;
    switch (kFields[f].field) {
      case Field::kHarmonic: i32 = c.harmonic; value = &i32; break;
      case Field::kTake: i32 = c.take; value = &i32; break;
      case Field::kCycle: i64 = c.cycle; value = &i64; break;
      case Field::kSequence: u64 = c.sequence; value = &u64; break;
      case Field::kIllumination: u8 = c.illumination ? 1 : 0; value = &u8; break;
      case Field::kFrequency: f64 = c.frequency_hz; value = &f64; break;
      case Field::kPhaseShift: f64 = c.phase_shift_rad; value = &f64; break;
      case Field::kExposure: f64 = c.exposure_s; value = &f64; break;
      case Field::kTimestamp: f64 = c.timestamp_s; value = &f64; break;
    }
    if (!AppendAt(metadata_[f].get(), index, {1}, storage.memory_type, value).ok()) {
      return write_failed(FramesObject(kFields[f].name));
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
  }
  return status;
}

absl::Status CaptureWriter::WriteGroup(const char* name, const GroundTruth* truth,
                                       const CalibrationTable* calibration) {
  if (closed_) return absl::FailedPreconditionError(absl::StrCat(path_, ": closed"));
  if (file_.valid()) {
    return absl::FailedPreconditionError(absl::StrCat(
        path_, ": /", name, " can only be added before the first frame (HDF5 1.10 cannot add "
        "objects to a file in SWMR mode)"));
  }
  h5::Id access = LatestFormatAccess();
  h5::Id file = h5::File(H5Fopen(path_.c_str(), H5F_ACC_RDWR, access.get()));
  if (!file.valid()) return absl::InternalError(absl::StrCat(path_, ": cannot reopen the capture"));
  if (H5Lexists(file.get(), name, H5P_DEFAULT) > 0) H5Ldelete(file.get(), name, H5P_DEFAULT);
  h5::Id group = h5::Group(H5Gcreate2(file.get(), name, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT));
  if (!group.valid()) return absl::InternalError(absl::StrCat(path_, ": cannot create /", name));
  absl::Status status = truth != nullptr ? WriteGroundTruthGroup(group.get(), *truth)
                                         : internal::WriteCalibrationGroup(group.get(), *calibration);
  if (!status.ok()) {
    return absl::InternalError(absl::StrCat(path_, ": /", name, ": ", status.message()));
  }
  group = h5::Id();
  if (!file.Close().ok()) return absl::InternalError(absl::StrCat(path_, ": closing failed"));
  return absl::OkStatus();
}

absl::Status CaptureWriter::SetGroundTruth(const GroundTruth& truth) {
  if (absl::Status status = CheckGroundTruth(truth, camera_.geometry); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(path_, ": ", status.message()));
  }
  return WriteGroup(kGroundTruthGroup, &truth, nullptr);
}

absl::Status CaptureWriter::EmbedCalibration(const CalibrationTable& calibration) {
  if (absl::Status status = internal::CheckCalibrationTable(calibration); !status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(path_, ": ", status.message()));
  }
  return WriteGroup(kCalibrationGroup, nullptr, &calibration);
}

// ---------------------------------------------------------------------------------------------
// CaptureReader

absl::StatusOr<CaptureReader> CaptureReader::Open(const std::string& path) {
  h5::SilenceErrorStack();
  if (absl::Status status = internal::CheckReadableHdf5File(path); !status.ok()) return status;
  CaptureReader reader;
  reader.path_ = path;
  reader.file_ = h5::File(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  if (!reader.file_.valid()) {
    // A recording that was killed, or is still being written, carries SWMR's marks in its
    // superblock, which a plain open refuses; SWMR read ignores them by design.
    h5::Id access = LatestFormatAccess();
    // SWMR readers retry a metadata block whose checksum fails, with exponential back-off, 100
    // times by default: right for a block a live writer is rewriting, endless for a file cut
    // short. A few attempts tell the two apart.
    H5Pset_metadata_read_attempts(access.get(), kSwmrReadAttempts);
    reader.file_ =
        h5::File(H5Fopen(path.c_str(), H5F_ACC_RDONLY | H5F_ACC_SWMR_READ, access.get()));
  }
  if (!reader.file_.valid()) {
    return absl::DataLossError(absl::StrCat(
        path, ": HDF5 cannot open the file (corrupt, truncated, or being written without SWMR)"));
  }
  if (absl::Status status = reader.ReadLayout(); !status.ok()) return status;
  return reader;
}

absl::Status CaptureReader::ReadLayout() {
  const hid_t file = file_.get();
  const std::string root = Where(path_, "/");
  absl::StatusOr<std::string> format = h5::ReadStringAttribute(file, "format", root);
  if (!format.ok()) return format.status();
  if (absl::Status tag = CheckFormatTag(*format, kCaptureFormatName, kCaptureFormatMajor);
      !tag.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(root, ": attribute format: ", tag.message()));
  }
  absl::StatusOr<std::string> source = h5::ReadStringAttribute(file, "source_uri", root);
  if (!source.ok()) return source.status();
  source_uri_ = *source;

  // /camera
  {
    absl::StatusOr<h5::Id> group = internal::OpenGroup(file, path_, "/camera");
    if (!group.ok()) return group.status();
    const hid_t g = group->get();
    const std::string where = Where(path_, "/camera");
    absl::StatusOr<int64_t> width =
        internal::ReadIntegerAttribute(g, "width", where, 1, internal::kMaxFilePixels);
    if (!width.ok()) return width.status();
    absl::StatusOr<int64_t> height =
        internal::ReadIntegerAttribute(g, "height", where, 1, internal::kMaxFilePixels);
    if (!height.ok()) return height.status();
    if (*width * *height > internal::kMaxFilePixels) {
      return absl::InvalidArgumentError(absl::StrCat(where, ": expected at most ",
                                                     internal::kMaxFilePixels, " pixels, found ",
                                                     *width, " x ", *height));
    }
    camera_.geometry = {.width = static_cast<int>(*width), .height = static_cast<int>(*height)};
    PinholeIntrinsics& k = camera_.intrinsics;
    for (auto [name, target] : {std::pair{"fx", &k.fx}, std::pair{"fy", &k.fy},
                                std::pair{"cx", &k.cx}, std::pair{"cy", &k.cy}}) {
      absl::StatusOr<double> value =
          internal::ReadFiniteAttribute(g, name, where, internal::Sign::kAny);
      if (!value.ok()) return value.status();
      *target = *value;
    }
    absl::StatusOr<std::vector<double>> distortion =
        internal::ReadDoubleArrayAttribute(g, "distortion", where, camera_.distortion.size());
    if (!distortion.ok()) return distortion.status();
    std::copy(distortion->begin(), distortion->end(), camera_.distortion.begin());
    absl::StatusOr<std::string> model = h5::ReadStringAttribute(g, "model", where);
    if (!model.ok()) return model.status();
    camera_.model = *model;
    absl::StatusOr<double> period =
        internal::ReadFiniteAttribute(g, "frame_period_s", where, internal::Sign::kNonNegative);
    if (!period.ok()) return period.status();
    camera_.frame_period_s = *period;
  }

  // /schedule
  {
    absl::StatusOr<h5::Id> group = internal::OpenGroup(file, path_, "/schedule");
    if (!group.ok()) return group.status();
    const hid_t g = group->get();
    const std::string where = Where(path_, "/schedule");
    ScheduleOptions options;
    absl::StatusOr<double> frequency =
        internal::ReadFiniteAttribute(g, "base_frequency_hz", where, internal::Sign::kPositive);
    if (!frequency.ok()) return frequency.status();
    absl::StatusOr<int64_t> order = internal::ReadIntegerAttribute(g, "order", where, 1, kMaxOrder);
    if (!order.ok()) return order.status();
    absl::StatusOr<std::string> sampling = h5::ReadStringAttribute(g, "sampling", where);
    if (!sampling.ok()) return sampling.status();
    absl::StatusOr<SamplingScheme> sampling_scheme = ParseSamplingScheme(*sampling);
    if (!sampling_scheme.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ": attribute sampling: ", sampling_scheme.status().message()));
    }
    absl::StatusOr<int64_t> phase_steps =
        internal::ReadIntegerAttribute(g, "phase_steps", where, 1, 1 << 20);
    if (!phase_steps.ok()) return phase_steps.status();
    absl::StatusOr<std::string> zeroth = h5::ReadStringAttribute(g, "zeroth", where);
    if (!zeroth.ok()) return zeroth.status();
    absl::StatusOr<ZerothScheme> zeroth_scheme = ParseZerothScheme(*zeroth);
    if (!zeroth_scheme.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ": attribute zeroth: ", zeroth_scheme.status().message()));
    }
    absl::StatusOr<double> proxy = internal::ReadFiniteAttribute(g, "proxy_frequency_hz", where,
                                                                 internal::Sign::kNonNegative);
    if (!proxy.ok()) return proxy.status();
    absl::StatusOr<double> exposure =
        internal::ReadFiniteAttribute(g, "exposure_s", where, internal::Sign::kPositive);
    if (!exposure.ok()) return exposure.status();
    absl::StatusOr<int64_t> takes = internal::ReadIntegerAttribute(g, "takes", where, 1, 1 << 20);
    if (!takes.ok()) return takes.status();
    absl::StatusOr<int64_t> raw_per_frame =
        internal::ReadIntegerAttribute(g, "raw_frames_per_frame", where, 1, int64_t{1} << 40);
    if (!raw_per_frame.ok()) return raw_per_frame.status();
    options = {.base_frequency_hz = *frequency,
               .order = static_cast<int>(*order),
               .sampling = *sampling_scheme,
               .phase_steps = static_cast<int>(*phase_steps),
               .zeroth = *zeroth_scheme,
               .proxy_frequency_hz = *proxy,
               .exposure_s = *exposure,
               .takes = static_cast<int>(*takes)};
    absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(options);
    if (!schedule.ok()) {
      return absl::InvalidArgumentError(absl::StrCat(where, ": ", schedule.status().message()));
    }
    if (schedule->raw_frames_per_frame() != *raw_per_frame) {
      return absl::InvalidArgumentError(absl::StrCat(
          where, ": attribute raw_frames_per_frame: expected ", schedule->raw_frames_per_frame(),
          " (", schedule->Describe(), "), found ", *raw_per_frame));
    }
    schedule_ = *std::move(schedule);
  }

  // /frames
  {
    absl::StatusOr<h5::Id> group = internal::OpenGroup(file, path_, kFramesGroup);
    if (!group.ok()) return group.status();
    absl::StatusOr<double> saturation = h5::ReadNumericAttribute(
        group->get(), "saturation_level", Where(path_, kFramesGroup));
    if (!saturation.ok()) return saturation.status();
    if (std::isnan(*saturation)) {
      return absl::InvalidArgumentError(absl::StrCat(
          Where(path_, kFramesGroup), ": attribute saturation_level: expected a number, found nan"));
    }
    saturation_level_ = static_cast<float>(*saturation);
  }
  if (absl::Status status = ReadFrameMetadata(); !status.ok()) return status;

  if (h5::LinkExists(file, "/ground_truth")) {
    absl::StatusOr<h5::Id> group = internal::OpenGroup(file, path_, "/ground_truth");
    if (!group.ok()) return group.status();
    absl::StatusOr<GroundTruth> truth = ReadGroundTruthGroup(file, path_, camera_.geometry);
    if (!truth.ok()) return truth.status();
    ground_truth_ = *std::move(truth);
  }
  if (h5::LinkExists(file, "/calibration")) {
    absl::StatusOr<CalibrationTable> calibration =
        internal::ReadCalibrationGroup(file, path_, "/calibration");
    if (!calibration.ok()) return calibration.status();
    calibration_ = *std::move(calibration);
  }
  return absl::OkStatus();
}

absl::Status CaptureReader::ReadFrameMetadata() {
  const hid_t file = file_.get();
  const hsize_t h = camera_.geometry.height, w = camera_.geometry.width;
  std::vector<hsize_t> dims;
  absl::StatusOr<h5::Id> pixels =
      internal::OpenDataset(file, path_, kPixelsPath, {H5T_NO_CLASS, 0, "uint16 or float32"}, 3,
                            "[frames, height, width]", &dims);
  if (!pixels.ok()) return pixels.status();
  const std::string pixels_where = Where(path_, kPixelsPath);
  {
    h5::Id type = h5::Datatype(H5Dget_type(pixels->get()));
    const H5T_class_t type_class = H5Tget_class(type.get());
    const size_t size = H5Tget_size(type.get());
    if (type_class == H5T_INTEGER && size == 2 && H5Tget_sign(type.get()) == H5T_SGN_NONE) {
      pixel_type_ = CapturePixelType::kUint16;
    } else if (type_class == H5T_FLOAT && size == 4) {
      pixel_type_ = CapturePixelType::kFloat32;
    } else {
      return absl::InvalidArgumentError(absl::StrCat(pixels_where, ": expected uint16 or float32, found ",
                                                     h5::DescribeType(type.get())));
    }
  }
  if (absl::Status status = internal::CheckShape(pixels_where, {dims[1], dims[2]}, {h, w},
                                                 "[height, width] of /camera");
      !status.ok()) {
    return status;
  }
  hsize_t frames = dims[0];

  // Per-frame values, read chunk by chunk so that a chunk torn off at the end of the file ends
  // the recording there instead of failing the whole dataset.
  std::vector<std::vector<int64_t>> integers(kFieldCount);
  std::vector<std::vector<double>> floats(kFieldCount);
  std::vector<h5::Id> datasets;
  for (int f = 0; f < kFieldCount; ++f) {
    const FieldSpec& spec = kFields[f];
    const std::string object = FramesObject(spec.name);
    absl::StatusOr<h5::Id> dataset = internal::OpenDataset(
        file, path_, object,
        spec.field == Field::kIllumination ? internal::kByte
        : spec.integer                     ? internal::kAnyInteger
                                           : internal::kAnyFloat,
        1, "[frames]", &dims);
    if (!dataset.ok()) return dataset.status();
    // Lengths may differ after a crash (the datasets are extended one after the other): the
    // frames all of them hold are the recording.
    frames = std::min(frames, dims[0]);
    datasets.push_back(*std::move(dataset));
  }
  // HDF5 reads the part of a block past the end of the file as zeros, without an error, when
  // the file's end-of-file check is off (as it is for SWMR readers): blocks are checked against
  // the file's real size.
  std::error_code error;
  const uintmax_t file_size = std::filesystem::file_size(path_, error);
  const auto chunk_inside_file = [&](hid_t dataset, const hsize_t* offset) {
    unsigned filter_mask = 0;
    haddr_t address = HADDR_UNDEF;
    hsize_t size = 0;
    if (H5Dget_chunk_info_by_coord(dataset, offset, &filter_mask, &address, &size) < 0) {
      return false;
    }
    // An unallocated chunk reads as fill values, which the completeness check below catches.
    return address == HADDR_UNDEF || error || address + size <= file_size;
  };
  for (int f = 0; f < kFieldCount; ++f) {
    const hid_t dataset = datasets[f].get();
    h5::Id creation = h5::PropertyList(H5Dget_create_plist(dataset));
    hsize_t block = frames;
    const bool chunked = H5Pget_layout(creation.get()) == H5D_CHUNKED;
    if (chunked) H5Pget_chunk(creation.get(), 1, &block);
    block = std::max<hsize_t>(block, 1);
    const bool integer = kFields[f].integer;
    const bool unsigned_64 = kFields[f].field == Field::kSequence;
    if (integer) {
      integers[f].resize(frames);
    } else {
      floats[f].resize(frames);
    }
    h5::Id file_space = h5::Dataspace(H5Dget_space(dataset));
    for (hsize_t start = 0; start < frames; start += block) {
      if (chunked && !chunk_inside_file(dataset, &start)) {
        frames = start;
        break;
      }
      const hsize_t count = std::min(block, frames - start);
      h5::Id memory = h5::Dataspace(H5Screate_simple(1, &count, nullptr));
      void* out = integer ? static_cast<void*>(integers[f].data() + start)
                          : static_cast<void*>(floats[f].data() + start);
      const hid_t memory_type = !integer      ? H5T_NATIVE_DOUBLE
                                : unsigned_64 ? H5T_NATIVE_UINT64
                                              : H5T_NATIVE_INT64;
      if (H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, &start, nullptr, &count,
                              nullptr) < 0 ||
          H5Dread(dataset, memory_type, memory.get(), file_space.get(), H5P_DEFAULT, out) < 0) {
        frames = start;
        break;
      }
    }
  }

  // A frame counts when every value was written (none is the fill value) and its pixel chunk
  // exists and lies inside the file: the end of a killed or truncated recording is not an error.
  h5::Id creation = h5::PropertyList(H5Dget_create_plist(pixels->get()));
  const bool chunked = H5Pget_layout(creation.get()) == H5D_CHUNKED;
  hsize_t chunk[3] = {1, h, w};
  if (chunked) H5Pget_chunk(creation.get(), 3, chunk);
  configs_.clear();
  configs_.reserve(frames);
  for (hsize_t i = 0; i < frames; ++i) {
    bool complete = true;
    ExposureConfig c;
    for (int f = 0; f < kFieldCount && complete; ++f) {
      const FieldStorage storage = StorageOf(kFields[f].field);
      switch (kFields[f].field) {
        case Field::kHarmonic: c.harmonic = static_cast<int>(integers[f][i]);
          complete = integers[f][i] != storage.fill.i32; break;
        case Field::kTake: c.take = static_cast<int>(integers[f][i]);
          complete = integers[f][i] != storage.fill.i32; break;
        case Field::kCycle: c.cycle = integers[f][i];
          complete = integers[f][i] != storage.fill.i64; break;
        case Field::kSequence: std::memcpy(&c.sequence, &integers[f][i], sizeof c.sequence);
          complete = c.sequence != storage.fill.u64; break;
        case Field::kIllumination: c.illumination = integers[f][i] != 0;
          complete = integers[f][i] != storage.fill.u8; break;
        case Field::kFrequency: c.frequency_hz = floats[f][i];
          complete = !std::isnan(floats[f][i]); break;
        case Field::kPhaseShift: c.phase_shift_rad = floats[f][i];
          complete = !std::isnan(floats[f][i]); break;
        case Field::kExposure: c.exposure_s = floats[f][i];
          complete = !std::isnan(floats[f][i]); break;
        case Field::kTimestamp: c.timestamp_s = floats[f][i];
          complete = !std::isnan(floats[f][i]); break;
      }
    }
    if (complete && chunked) {
      for (hsize_t y = 0; y < h && complete; y += chunk[1]) {
        for (hsize_t x = 0; x < w && complete; x += chunk[2]) {
          const hsize_t offset[3] = {i - i % chunk[0], y, x};
          unsigned filter_mask = 0;
          haddr_t address = HADDR_UNDEF;
          hsize_t size = 0;
          complete = H5Dget_chunk_info_by_coord(pixels->get(), offset, &filter_mask, &address,
                                                &size) >= 0 &&
                     address != HADDR_UNDEF && chunk_inside_file(pixels->get(), offset);
        }
      }
    }
    if (!complete) break;
    configs_.push_back(c);
  }
  frames_ = static_cast<int64_t>(configs_.size());
  pixels_ = *std::move(pixels);
  return absl::OkStatus();
}

absl::Status CaptureReader::Read(int64_t index, RawFrame* frame) const {
  if (index < 0 || index >= frames_) {
    return absl::OutOfRangeError(absl::StrCat(path_, ": frame ", index, " is outside 0..",
                                              frames_ - 1));
  }
  const ImageGeometry g = camera_.geometry;
  frame->config = configs_[index];
  frame->geometry = g;
  frame->saturation_level = saturation_level_;
  frame->pixels.resize(g.pixel_count());
  const hsize_t start[3] = {static_cast<hsize_t>(index), 0, 0};
  const hsize_t count[3] = {1, static_cast<hsize_t>(g.height), static_cast<hsize_t>(g.width)};
  h5::Id memory = h5::Dataspace(H5Screate_simple(3, count, nullptr));
  h5::Id selection = h5::Dataspace(H5Dget_space(pixels_.get()));
  if (H5Sselect_hyperslab(selection.get(), H5S_SELECT_SET, start, nullptr, count, nullptr) < 0 ||
      H5Dread(pixels_.get(), H5T_NATIVE_FLOAT, memory.get(), selection.get(), H5P_DEFAULT,
              frame->pixels.data()) < 0) {
    return absl::DataLossError(absl::StrCat(path_, ": ", kPixelsPath, ": cannot read frame ",
                                            index, " (corrupt chunk)"));
  }
  return absl::OkStatus();
}

}  // namespace transient
