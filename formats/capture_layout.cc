// Storage of the per-frame datasets of capture files.
#include "capture_layout.h"

#include <cmath>
#include <cstring>
#include <limits>

#include "absl/strings/str_cat.h"

namespace transient::capture_layout {

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

hid_t ExchangeType(Field field) {
  if (field == Field::kSequence) return H5T_NATIVE_UINT64;
  return kFields[static_cast<int>(field)].integer ? H5T_NATIVE_INT64 : H5T_NATIVE_DOUBLE;
}

FieldValue ValueOf(Field field, const ExposureConfig& config) {
  FieldValue value;
  switch (field) {
    case Field::kHarmonic:
      value.integer = config.harmonic;
      break;
    case Field::kTake:
      value.integer = config.take;
      break;
    case Field::kCycle:
      value.integer = config.cycle;
      break;
    case Field::kSequence:
      std::memcpy(&value.integer, &config.sequence, sizeof value.integer);
      break;
    case Field::kIllumination:
      value.integer = config.illumination ? 1 : 0;
      break;
    case Field::kFrequency:
      value.real = config.frequency_hz;
      break;
    case Field::kPhaseShift:
      value.real = config.phase_shift_rad;
      break;
    case Field::kExposure:
      value.real = config.exposure_s;
      break;
    case Field::kTimestamp:
      value.real = config.timestamp_s;
      break;
  }
  return value;
}

bool SetFrom(Field field, FieldValue value, ExposureConfig* config) {
  const FieldStorage storage = StorageOf(field);
  switch (field) {
    case Field::kHarmonic:
      config->harmonic = static_cast<int>(value.integer);
      return value.integer != storage.fill.i32;
    case Field::kTake:
      config->take = static_cast<int>(value.integer);
      return value.integer != storage.fill.i32;
    case Field::kCycle:
      config->cycle = value.integer;
      return value.integer != storage.fill.i64;
    case Field::kSequence:
      std::memcpy(&config->sequence, &value.integer, sizeof config->sequence);
      return config->sequence != storage.fill.u64;
    case Field::kIllumination:
      config->illumination = value.integer != 0;
      return value.integer != storage.fill.u8;
    case Field::kFrequency:
      config->frequency_hz = value.real;
      return !std::isnan(value.real);
    case Field::kPhaseShift:
      config->phase_shift_rad = value.real;
      return !std::isnan(value.real);
    case Field::kExposure:
      config->exposure_s = value.real;
      return !std::isnan(value.real);
    case Field::kTimestamp:
      config->timestamp_s = value.real;
      return !std::isnan(value.real);
  }
  return false;
}

std::string FramesObject(const char* name) { return absl::StrCat(kFramesGroup, "/", name); }

}  // namespace transient::capture_layout
