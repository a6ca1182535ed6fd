// The Kinect v2 depth stream's data format (kinect2_format.h).
#include "kinect2_format.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>

#include "absl/strings/str_cat.h"

namespace transient::kinect2 {
namespace {

constexpr double kPi = std::numbers::pi;

std::array<int16_t, 2048> MakeTable() {
  std::array<int16_t, 2048> table{};
  for (int code = 0; code < 1024; ++code) {
    int value = code;
    if (code >= 256) {
      const int run = (code - 256) / 128;  // 0..5
      value = (256 << run) + (2 << run) * ((code - 256) % 128);
    }
    table[static_cast<size_t>(code)] = static_cast<int16_t>(value);
    table[static_cast<size_t>(1024 + code)] = static_cast<int16_t>(-value);
  }
  table[kSaturatedCode] = kSaturatedValue;
  return table;
}

}  // namespace

const std::array<int16_t, 2048>& CompandingTable() {
  static const std::array<int16_t, 2048> table = MakeTable();
  return table;
}

float QuantizeSample(double value) {
  if (std::isnan(value)) return std::numeric_limits<float>::quiet_NaN();
  const double magnitude = std::abs(value);
  double q;
  if (magnitude < 255.5) {
    q = std::floor(magnitude + 0.5);
  } else {
    // Run k covers [256 * 2^k, 256 * 2^k + 127 * step] with step 2^(k+1).
    int run = 0;
    while (run < 5 && magnitude >= (512 << run) - (1 << run)) ++run;  // past the run's midpoint
    const double base = 256 << run, step = 2 << run;
    double index = std::floor((magnitude - base) / step + 0.5);
    if (index < 0.0) index = 0.0;
    if (index > 127.0) {
      if (magnitude > kMaxMagnitude + 0.5 * 64) return kSaturatedValue;
      index = 127.0;
    }
    q = base + step * index;
  }
  return static_cast<float>(value < 0.0 ? -q : q);
}

int SubImageRow(int output_row) { return output_row < kHeight / 2 ? output_row : 635 - output_row; }

int Slot(int x) { return (x >> 2) + ((x & 3) << 7); }

absl::Status UnpackSubImage(std::span<const uint8_t> payload, std::span<float> out) {
  if (payload.size() != kSubImageBytes || out.size() != size_t{kWidth} * kHeight) {
    return absl::InvalidArgumentError(absl::StrCat(
        "Kinect v2 sub-image of ", payload.size(), " bytes into ", out.size(),
        " pixels. Violated constraint: ", kSubImageBytes, " bytes into ", kWidth * kHeight));
  }
  const std::array<int16_t, 2048>& table = CompandingTable();
  // The column of each slot, once.
  static const std::array<int, kWidth> column_of_slot = [] {
    std::array<int, kWidth> c{};
    for (int x = 0; x < kWidth; ++x) c[static_cast<size_t>(Slot(x))] = x;
    return c;
  }();
  for (int r = 0; r < kHeight; ++r) {
    const uint8_t* row = payload.data() + size_t(SubImageRow(r)) * kRowBytes;
    float* o = out.data() + size_t(r) * kWidth;
    // Little-endian bit stream: refill a 64-bit accumulator a byte at a time.
    uint64_t bits = 0;
    int have = 0;
    size_t next = 0;
    for (int s = 0; s < kWidth; ++s) {
      while (have < kBitsPerSample) {
        bits |= static_cast<uint64_t>(row[next++]) << have;
        have += 8;
      }
      const uint16_t code = static_cast<uint16_t>(bits & 0x7FF);
      bits >>= kBitsPerSample;
      have -= kBitsPerSample;
      o[column_of_slot[static_cast<size_t>(s)]] = table[code];
    }
    o[0] = o[kWidth - 1] = std::numeric_limits<float>::quiet_NaN();
  }
  return absl::OkStatus();
}

Footer ParseFooter(std::span<const uint8_t, kFooterBytes> bytes) {
  Footer f;
  const uint8_t* p = bytes.data();
  f.magic0 = LoadLe32(p);
  f.magic1 = LoadLe32(p + 4);
  f.timestamp = LoadLe32(p + 8);
  f.sequence = LoadLe32(p + 12);
  f.subsequence = LoadLe32(p + 16);
  f.length = LoadLe32(p + 20);
  for (size_t i = 0; i < f.fields.size(); ++i) f.fields[i] = LoadLe32(p + 24 + 4 * i);
  return f;
}

ScheduleOptions Schedule() {
  ScheduleOptions o;
  o.base_frequency_hz = kBaseFrequencyHz;
  o.order = 15;
  o.harmonics = {kGroupHarmonics[0], kGroupHarmonics[1], kGroupHarmonics[2]};
  o.buckets = 3;
  o.sampling = SamplingScheme::kFourBucket;  // one phase per exposure
  o.phase_steps = 1;
  o.zeroth = ZerothScheme::kEstimated;
  o.exposure_s = kNominalExposureS;
  o.takes = 1;
  return o;
}

ExposureConfig SubFrameExposure(int subframe) {
  ExposureConfig e;
  e.harmonic = kGroupHarmonics[subframe / 3];
  e.frequency_hz = e.harmonic * kBaseFrequencyHz;
  e.phase_shift_rad = BucketPhaseShift((3 - subframe % 3) % 3, 3);
  e.exposure_s = kNominalExposureS;
  e.illumination = true;
  return e;
}

double P0Phase(uint16_t value) { return -static_cast<double>(value) * 0.000031 * kPi; }

absl::StatusOr<CalibrationTable> CalibrationFromP0(std::span<const uint8_t> response) {
  if (response.size() < kP0ResponseBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("Kinect v2 P0 tables response of ", response.size(),
                     " bytes. Violated constraint: at least ", kP0ResponseBytes));
  }
  const ScheduleOptions schedule = Schedule();
  const int64_t pixels = int64_t{kWidth} * kHeight;
  CalibrationTable table;
  table.geometry = {kWidth, kHeight};
  table.order = schedule.order;
  table.base_frequency_hz = schedule.base_frequency_hz;
  table.schedule = schedule;
  table.takes_averaged = 1;
  table.real.assign(static_cast<size_t>((schedule.order + 1) * pixels), 1.0f);
  table.imag.assign(static_cast<size_t>((schedule.order + 1) * pixels), 0.0f);
  table.valid.assign(static_cast<size_t>(pixels), 1);
  const size_t table_bytes = 2 + 2 * static_cast<size_t>(pixels) + 2;
  for (int g = 0; g < 3; ++g) {
    const uint8_t* values = response.data() + 32 + g * table_bytes + 2;
    const int j = kGroupHarmonics[g];
    float* re = table.real.data() + j * pixels;
    float* im = table.imag.data() + j * pixels;
    for (int64_t p = 0; p < pixels; ++p) {
      const double phase = -P0Phase(LoadLe16(values + 2 * p));
      re[p] = static_cast<float>(std::cos(phase));
      im[p] = static_cast<float>(std::sin(phase));
    }
  }
  return table;
}

}  // namespace transient::kinect2
