// The names and storage of a capture file's objects (layout in capture_file.h), shared by its
// writer (capture_writer.cc) and its reader (capture_reader.cc).
#pragma once

#include <hdf5.h>

#include <cstdint>
#include <string>

#include "transient/reconstruct/acquisition.h"

namespace transient::capture_layout {

inline constexpr char kFramesGroup[] = "/frames";
inline constexpr char kPixelsPath[] = "/frames/pixels";
inline constexpr char kCameraGroup[] = "/camera";
inline constexpr char kScheduleGroup[] = "/schedule";
inline constexpr char kGroundTruthGroup[] = "/ground_truth";
inline constexpr char kCalibrationGroup[] = "/calibration";

// One per-frame dataset: its name, its file type, and the fill value that marks an entry
// that was never written (no frame can hold it).
enum class Field {
  kHarmonic,
  kFrequency,
  kPhaseShift,
  kExposure,
  kIllumination,
  kTake,
  kCycle,
  kSequence,
  kTimestamp
};
inline constexpr int kFieldCount = 9;
struct FieldSpec {
  Field field;
  const char* name;
  bool integer;
};
// In the order of the datasets in capture_file.h.
inline constexpr FieldSpec kFields[kFieldCount] = {
    {Field::kHarmonic, "harmonic", true},
    {Field::kFrequency, "frequency_hz", false},
    {Field::kPhaseShift, "phase_shift_rad", false},
    {Field::kExposure, "exposure_s", false},
    {Field::kIllumination, "illumination", true},
    {Field::kTake, "take", true},
    {Field::kCycle, "cycle", true},
    {Field::kSequence, "sequence", true},
    {Field::kTimestamp, "timestamp_s", false},
};

constexpr bool FieldsAreInEnumOrder() {
  for (int i = 0; i < kFieldCount; ++i) {
    if (static_cast<int>(kFields[i].field) != i) return false;
  }
  return true;
}
static_assert(FieldsAreInEnumOrder(), "kFields is indexed by Field");

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
FieldStorage StorageOf(Field field);

// A frame's value of one field as it travels to and from HDF5: integer fields as int64 (the
// sequence as the bits of its uint64), float fields as double; HDF5 converts to and from the
// file type.
struct FieldValue {
  int64_t integer = 0;
  double real = 0.0;
};
// H5T_NATIVE_INT64, H5T_NATIVE_UINT64 (sequence) or H5T_NATIVE_DOUBLE.
hid_t ExchangeType(Field field);
FieldValue ValueOf(Field field, const ExposureConfig& config);
// Sets `field` of `config` from `value`; false when `value` is the field's fill value: the entry
// was never written.
bool SetFrom(Field field, FieldValue value, ExposureConfig* config);

// "/frames/<name>".
std::string FramesObject(const char* name);

}  // namespace transient::capture_layout
