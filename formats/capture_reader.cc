// Reader of capture files (layout in capture_file.h): checks the whole layout at Open and counts
// only the frames that were completely written, so that a killed or truncated recording reads
// up to its torn tail.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <utility>
#include <vector>

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

using h5::Where;

// Far more raw frames per transient frame than any schedule that validates has.
constexpr int64_t kMaxRawFramesPerFrame = int64_t{1} << 40;

}  // namespace

absl::StatusOr<CaptureReader> CaptureReader::Open(const std::string& path) {
  // A recording that was killed, or is still being written, carries SWMR's marks in its
  // superblock, which a plain open refuses; SWMR read ignores them by design.
  absl::StatusOr<h5::Id> file =
      h5::OpenFileForReading(path, "an HDF5 capture file", h5::SwmrRead::kAllow);
  if (!file.ok()) return file.status();
  CaptureReader reader;
  reader.path_ = path;
  reader.file_ = *std::move(file);
  if (absl::Status status = reader.ReadLayout(); !status.ok()) return status;
  return reader;
}

absl::Status CaptureReader::ReadLayout() {
  const hid_t file = file_.get();
  const std::string root = Where(path_, "/");
  if (absl::Status status =
          ReadFormatAttribute(file, root, kCaptureFormatName, kCaptureFormatMajor);
      !status.ok()) {
    return status;
  }
  absl::StatusOr<std::string> source = h5::ReadStringAttribute(file, "source_uri", root);
  if (!source.ok()) return source.status();
  source_uri_ = *source;

  // /camera
  {
    absl::StatusOr<h5::Id> group = h5::OpenGroup(file, path_, layout::kCameraGroup);
    if (!group.ok()) return group.status();
    const hid_t g = group->get();
    const std::string where = Where(path_, layout::kCameraGroup);
    absl::StatusOr<int64_t> width =
        h5::ReadIntegerAttribute(g, "width", where, 1, h5::kMaxImagePixels);
    if (!width.ok()) return width.status();
    absl::StatusOr<int64_t> height =
        h5::ReadIntegerAttribute(g, "height", where, 1, h5::kMaxImagePixels);
    if (!height.ok()) return height.status();
    if (absl::Status status = h5::CheckImageSize(where, *height, *width); !status.ok()) {
      return status;
    }
    camera_.geometry = {.width = static_cast<int>(*width), .height = static_cast<int>(*height)};
    PinholeIntrinsics& k = camera_.intrinsics;
    for (auto [name, target] : {std::pair{"fx", &k.fx}, std::pair{"fy", &k.fy},
                                std::pair{"cx", &k.cx}, std::pair{"cy", &k.cy}}) {
      absl::StatusOr<double> value = h5::ReadFiniteAttribute(g, name, where, h5::Sign::kAny);
      if (!value.ok()) return value.status();
      *target = *value;
    }
    absl::StatusOr<std::vector<double>> distortion =
        h5::ReadDoubleArrayAttribute(g, "distortion", where, camera_.distortion.size());
    if (!distortion.ok()) return distortion.status();
    std::copy(distortion->begin(), distortion->end(), camera_.distortion.begin());
    absl::StatusOr<std::string> model = h5::ReadStringAttribute(g, "model", where);
    if (!model.ok()) return model.status();
    camera_.model = *model;
    absl::StatusOr<double> period =
        h5::ReadFiniteAttribute(g, "frame_period_s", where, h5::Sign::kNonNegative);
    if (!period.ok()) return period.status();
    camera_.frame_period_s = *period;
  }

  // /schedule
  {
    absl::StatusOr<h5::Id> group = h5::OpenGroup(file, path_, layout::kScheduleGroup);
    if (!group.ok()) return group.status();
    const hid_t g = group->get();
    const std::string where = Where(path_, layout::kScheduleGroup);
    absl::StatusOr<ScheduleOptions> options =
        ReadScheduleAttributes(g, where, TakesAttribute::kRequired);
    if (!options.ok()) return options.status();
    absl::StatusOr<int64_t> raw_per_frame =
        h5::ReadIntegerAttribute(g, "raw_frames_per_frame", where, 1, kMaxRawFramesPerFrame);
    if (!raw_per_frame.ok()) return raw_per_frame.status();
    absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(*options);
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
    absl::StatusOr<h5::Id> group = h5::OpenGroup(file, path_, layout::kFramesGroup);
    if (!group.ok()) return group.status();
    absl::StatusOr<double> saturation = h5::ReadNumericAttribute(
        group->get(), "saturation_level", Where(path_, layout::kFramesGroup));
    if (!saturation.ok()) return saturation.status();
    if (std::isnan(*saturation)) {
      return absl::InvalidArgumentError(
          absl::StrCat(Where(path_, layout::kFramesGroup),
                       ": attribute saturation_level: expected a number, found nan"));
    }
    saturation_level_ = static_cast<float>(*saturation);
  }
  if (absl::Status status = ReadFrameMetadata(); !status.ok()) return status;

  if (h5::LinkExists(file, layout::kGroundTruthGroup)) {
    absl::StatusOr<h5::Id> group = h5::OpenGroup(file, path_, layout::kGroundTruthGroup);
    if (!group.ok()) return group.status();
    absl::StatusOr<GroundTruth> truth = ReadGroundTruthGroup(file, path_, camera_.geometry);
    if (!truth.ok()) return truth.status();
    ground_truth_ = *std::move(truth);
  }
  if (h5::LinkExists(file, layout::kCalibrationGroup)) {
    absl::StatusOr<CalibrationTable> calibration =
        ReadCalibrationGroup(file, path_, layout::kCalibrationGroup);
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
      h5::OpenDataset(file, path_, layout::kPixelsPath, {H5T_NO_CLASS, 0, "uint16 or float32"}, 3,
                      "[frames, height, width]", &dims);
  if (!pixels.ok()) return pixels.status();
  const std::string pixels_where = Where(path_, layout::kPixelsPath);
  {
    h5::Id type = h5::Datatype(H5Dget_type(pixels->get()));
    const H5T_class_t type_class = H5Tget_class(type.get());
    const size_t size = H5Tget_size(type.get());
    if (type_class == H5T_INTEGER && size == 2 && H5Tget_sign(type.get()) == H5T_SGN_NONE) {
      pixel_type_ = CapturePixelType::kUint16;
    } else if (type_class == H5T_FLOAT && size == 4) {
      pixel_type_ = CapturePixelType::kFloat32;
    } else {
      return absl::InvalidArgumentError(absl::StrCat(
          pixels_where, ": expected uint16 or float32, found ", h5::DescribeType(type.get())));
    }
  }
  if (absl::Status status =
          h5::CheckShape(pixels_where, {dims[1], dims[2]}, {h, w}, "[height, width] of /camera");
      !status.ok()) {
    return status;
  }
  hsize_t frames = dims[0];

  // Per-frame values, read chunk by chunk so that a chunk torn off at the end of the file ends
  // the recording there instead of failing the whole dataset.
  std::vector<std::vector<int64_t>> integers(layout::kFieldCount);
  std::vector<std::vector<double>> floats(layout::kFieldCount);
  std::vector<h5::Id> datasets;
  for (int f = 0; f < layout::kFieldCount; ++f) {
    const layout::FieldSpec& spec = layout::kFields[f];
    const std::string object = layout::FramesObject(spec.name);
    absl::StatusOr<h5::Id> dataset =
        h5::OpenDataset(file, path_, object,
                        spec.field == layout::Field::kIllumination ? h5::kByte
                        : spec.integer                             ? h5::kAnyInteger
                                                                   : h5::kAnyFloat,
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
  for (int f = 0; f < layout::kFieldCount; ++f) {
    const hid_t dataset = datasets[f].get();
    h5::Id creation = h5::PropertyList(H5Dget_create_plist(dataset));
    hsize_t block = frames;
    const bool chunked = H5Pget_layout(creation.get()) == H5D_CHUNKED;
    if (chunked) H5Pget_chunk(creation.get(), 1, &block);
    block = std::max<hsize_t>(block, 1);
    const bool integer = layout::kFields[f].integer;
    const hid_t memory_type = layout::ExchangeType(layout::kFields[f].field);
    if (integer) {
      integers[f].resize(frames);
    } else {
      floats[f].resize(frames);
    }
    for (hsize_t start = 0; start < frames; start += block) {
      if (chunked && !chunk_inside_file(dataset, &start)) {
        frames = start;
        break;
      }
      const hsize_t count = std::min(block, frames - start);
      void* out = integer ? static_cast<void*>(integers[f].data() + start)
                          : static_cast<void*>(floats[f].data() + start);
      if (!h5::ReadBlock(dataset, {start}, {count}, memory_type, out).ok()) {
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
    for (int f = 0; f < layout::kFieldCount && complete; ++f) {
      const bool integer = layout::kFields[f].integer;
      const layout::FieldValue value = {.integer = integer ? integers[f][i] : 0,
                                        .real = integer ? 0.0 : floats[f][i]};
      complete = layout::SetFrom(layout::kFields[f].field, value, &c);
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
    return absl::OutOfRangeError(
        absl::StrCat(path_, ": frame ", index, " is outside 0..", frames_ - 1));
  }
  const ImageGeometry g = camera_.geometry;
  frame->config = configs_[index];
  frame->geometry = g;
  frame->saturation_level = saturation_level_;
  frame->pixels.resize(g.pixel_count());
  const hsize_t height = g.height, width = g.width;
  const std::vector<hsize_t> start = {static_cast<hsize_t>(index), 0, 0},
                             count = {1, height, width};
  const auto corrupt = [&] {
    return absl::DataLossError(absl::StrCat(path_, ": ", layout::kPixelsPath,
                                            ": cannot read frame ", index, " (corrupt chunk)"));
  };
  if (pixel_type_ == CapturePixelType::kUint16) {
    // Read as stored and widened here (exactly: every uint16 is a float). HDF5's own conversion
    // to float (H5T__conv_ushort_float) was ~3 % of transientd's CPU on a VGA replay, about
    // 0.8 ns a pixel; this loop vectorizes. One buffer per reading thread, kept.
    thread_local std::vector<uint16_t> stored;
    stored.resize(frame->pixels.size());
    if (!h5::ReadBlock(pixels_.get(), start, count, H5T_NATIVE_UINT16, stored.data()).ok()) {
      return corrupt();
    }
    std::copy(stored.begin(), stored.end(), frame->pixels.begin());
    return absl::OkStatus();
  }
  if (!h5::ReadBlock(pixels_.get(), start, count, H5T_NATIVE_FLOAT, frame->pixels.data()).ok()) {
    return corrupt();
  }
  return absl::OkStatus();
}

}  // namespace transient
