// The Kinect v2 data format: the companding table for all 2048 codes, the sub-image layout
// against a packer written here from the description (research/libusb.md §1.4), the footer,
// which sub-frame is which exposure, and the P0 tables as a calibration.
#include "kinect2/kinect2_format.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <functional>
#include <numbers>
#include <random>
#include <vector>

#include "tests/support/status_matchers.h"
#include "transient/reconstruct/demodulation.h"

namespace transient::kinect2 {
namespace {

using ::testing::HasSubstr;
using ::transient::testing::IsOk;
using ::transient::testing::StatusIs;

constexpr double kPi = std::numbers::pi;

TEST(Companding, AllTwoThousandFortyEightCodes) {
  const std::array<int16_t, 2048>& table = CompandingTable();
  // Run starts double: 256, 512, ..., 8192, the last value 8192 + 127 * 64 = 16320.
  std::vector<int> magnitude(1024);
  for (int code = 0; code < 256; ++code) magnitude[code] = code;
  for (int run = 0; run < 6; ++run) {
    for (int k = 0; k < 128; ++k) magnitude[256 + 128 * run + k] = (256 << run) + k * (2 << run);
  }
  EXPECT_EQ(magnitude[1023], 16320);
  for (int code = 0; code < 1024; ++code) {
    EXPECT_EQ(table[code], magnitude[code]) << code;
    if (code > 0) {
      EXPECT_EQ(table[1024 + code], -magnitude[code]) << 1024 + code;
    }
  }
  EXPECT_EQ(table[1024], 32767);  // saturation, not -0
  // Spot values of the description.
  EXPECT_EQ(table[255], 255);
  EXPECT_EQ(table[256], 256);
  EXPECT_EQ(table[257], 258);
  EXPECT_EQ(table[384], 512);
  EXPECT_EQ(table[1025], -1);
  EXPECT_EQ(table[2047], -16320);
}

TEST(Companding, QuantizeKeepsEveryTableValueAndRoundsToTheNearest) {
  const std::array<int16_t, 2048>& table = CompandingTable();
  for (int code = 0; code < 2048; ++code) {
    if (code == kSaturatedCode) continue;
    EXPECT_EQ(QuantizeSample(table[code]), table[code]) << code;
  }
  EXPECT_EQ(QuantizeSample(300.9), 300.0f);   // step 2 from 256
  EXPECT_EQ(QuantizeSample(301.1), 302.0f);
  EXPECT_EQ(QuantizeSample(-1000.0), -1000.0f);  // 512 + 122 * 4
  EXPECT_EQ(QuantizeSample(16330.0), 16320.0f);  // within half a step of the largest
  EXPECT_EQ(QuantizeSample(16400.0), 32767.0f);  // beyond: saturated
  EXPECT_EQ(QuantizeSample(-20000.0), 32767.0f);
  EXPECT_TRUE(std::isnan(QuantizeSample(NAN)));
}

// A sub-image packed from the description: output row r is sub-image row r for r < 212 and
// 635 - r below; column x sits in slot x/4 + 128*(x%4); slot s's 11 bits start at bit 11*s of
// the row, least significant bit first, in little-endian 16-bit words.
std::vector<uint8_t> Pack(const std::vector<uint16_t>& codes /* [424][512] output order */) {
  std::vector<uint16_t> words(kSubImageBytes / 2, 0);
  for (int r = 0; r < 424; ++r) {
    const int raw = r < 212 ? r : 635 - r;
    for (int x = 0; x < 512; ++x) {
      const int slot = x / 4 + 128 * (x % 4);
      for (int b = 0; b < 11; ++b) {
        if ((codes[r * 512 + x] >> b & 1) == 0) continue;
        const int bit = 11 * slot + b;
        words[raw * 352 + bit / 16] |= static_cast<uint16_t>(1u << (bit % 16));
      }
    }
  }
  std::vector<uint8_t> bytes;
  for (uint16_t w : words) {
    bytes.push_back(static_cast<uint8_t>(w & 0xFF));
    bytes.push_back(static_cast<uint8_t>(w >> 8));
  }
  return bytes;
}

TEST(SubImage, UnpacksRowsColumnsAndCodesAsDescribed) {
  std::mt19937 rng(5);
  std::vector<uint16_t> codes(512 * 424);
  for (uint16_t& c : codes) c = static_cast<uint16_t>(rng() % 2048);
  codes[100 * 512 + 7] = kSaturatedCode;
  const std::vector<uint8_t> payload = Pack(codes);
  ASSERT_EQ(payload.size(), kSubImageBytes);
  std::vector<float> out(512 * 424);
  ASSERT_THAT(UnpackSubImage(payload, out), IsOk());
  for (int r = 0; r < 424; ++r) {
    EXPECT_TRUE(std::isnan(out[r * 512])) << r;  // dead columns
    EXPECT_TRUE(std::isnan(out[r * 512 + 511])) << r;
    for (int x = 1; x < 511; ++x) {
      ASSERT_EQ(out[r * 512 + x], CompandingTable()[codes[r * 512 + x]]) << r << " " << x;
    }
  }
  EXPECT_EQ(out[100 * 512 + 7], 32767.0f);
  EXPECT_EQ(SubImageRow(0), 0);
  EXPECT_EQ(SubImageRow(211), 211);
  EXPECT_EQ(SubImageRow(212), 423);
  EXPECT_EQ(SubImageRow(423), 212);
  EXPECT_EQ(Slot(5), 129);
}

TEST(SubImage, AWrongSizeIsRefused) {
  std::vector<uint8_t> payload(kSubImageBytes - 1);
  std::vector<float> out(512 * 424);
  EXPECT_THAT(UnpackSubImage(payload, out),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("sub-image of 298495 bytes into 217088 pixels")));
}

TEST(Footer, FieldsAreLittleEndianU32s) {
  std::array<uint8_t, kFooterBytes> bytes{};
  auto put = [&](size_t at, uint32_t v) {
    for (int i = 0; i < 4; ++i) bytes[at + i] = static_cast<uint8_t>(v >> (8 * i));
  };
  put(8, 0x01020304);
  put(12, 77);
  put(16, 9);
  put(20, 298496);
  put(24 + 4 * 31, 0xDEADBEEF);
  const Footer f = ParseFooter(bytes);
  EXPECT_EQ(f.timestamp, 0x01020304u);
  EXPECT_EQ(f.sequence, 77u);
  EXPECT_EQ(f.subsequence, 9u);
  EXPECT_EQ(f.length, kSubImageBytes);
  EXPECT_EQ(f.fields[31], 0xDEADBEEFu);
}

// The moments of one pixel whose nine correlation sub-frames hold sample(g, k) (group g,
// phase step k), through the demodulator with the camera's schedule.
MomentImage DemodulateOnePixel(const std::function<double(int g, int k)>& sample) {
  absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(Schedule());
  EXPECT_THAT(schedule.status(), IsOk());
  std::vector<RawFrame> frames;
  for (int s = 0; s < kCorrelationSubFrames; ++s) {
    RawFrame frame;
    frame.config = SubFrameExposure(s);
    frame.config.sequence = static_cast<uint64_t>(s);
    frame.geometry = {1, 1};
    frame.pixels = {static_cast<float>(sample(s / 3, s % 3))};
    EXPECT_THAT(schedule->IndexOf(frame.config).status(), IsOk()) << s;
    frames.push_back(frame);
  }
  absl::StatusOr<Demodulator> demodulator =
      Demodulator::Create(*schedule, ImageGeometry{1, 1}, DemodulationOptions{});
  EXPECT_THAT(demodulator.status(), IsOk());
  MomentImage moments;
  EXPECT_THAT(demodulator->Demodulate(frames, &moments), IsOk());
  return moments;
}

TEST(SubFrames, AreTheScheduleExposuresAndDemodulateLikeLibfreenect2) {
  absl::StatusOr<AcquisitionSchedule> schedule = AcquisitionSchedule::Create(Schedule());
  ASSERT_THAT(schedule.status(), IsOk());
  ASSERT_EQ(schedule->raw_frames_per_frame(), kCorrelationSubFrames);
  // Sub-frame k of a group measures m_k = O + B cos(phi + 2*pi*k/3) (libfreenect2's model,
  // which it demodulates with sum m_k exp(-i*2*pi*k/3) into (3B/2) exp(i*phi)).
  const double phi[3] = {0.7, 2.9, 5.1}, b[3] = {100.0, 80.0, 60.0};
  const MomentImage moments = DemodulateOnePixel(
      [&](int g, int k) { return 500.0 + b[g] * std::cos(phi[g] + 2.0 * kPi * k / 3.0); });
  for (int g = 0; g < 3; ++g) {
    const int j = kGroupHarmonics[g];
    const std::complex<double> c(moments.real_plane(j)[0], moments.imag_plane(j)[0]);
    EXPECT_NEAR(std::abs(c), b[g], 1e-3) << j;
    EXPECT_NEAR(std::remainder(std::arg(c) - phi[g], 2.0 * kPi), 0.0, 1e-5) << j;
  }
  EXPECT_EQ(SubFrameExposure(4).harmonic, 2);
  EXPECT_DOUBLE_EQ(SubFrameExposure(4).frequency_hz, 16e6);
  EXPECT_DOUBLE_EQ(SubFrameExposure(8).frequency_hz, 120e6);
}

// libfreenect2's model with its P0 offset: sub-frame k of group g measures
// m_k = O + B cos(phi + 2*pi*k/3 + p0), p0 = -P0 * 0.000031 * pi, and its demodulation
// sum_k m_k exp(-i*(2*pi*k/3 + p0)) gives (3B/2) exp(i*phi) (research/libusb.md §1.5). Our
// demodulation followed by the calibration of CalibrationFromP0 must find the same phi.
TEST(P0Tables, DemodulationWithTheirCalibrationFindsLibfreenect2sPhase) {
  const uint16_t p0_raw[3] = {11482, 2284, 17128};  // e.g. the rows' edge values it reports
  const double phi[3] = {1.1, 4.0, 2.2};
  std::vector<uint8_t> response(kP0ResponseBytes, 0);
  const size_t table_bytes = 2 + 2 * 512 * 424 + 2;
  for (int g = 0; g < 3; ++g) {  // pixel (0, 0) of a 1 x 1 crop: the table's first value
    response[32 + g * table_bytes + 2] = static_cast<uint8_t>(p0_raw[g] & 0xFF);
    response[32 + g * table_bytes + 3] = static_cast<uint8_t>(p0_raw[g] >> 8);
  }
  absl::StatusOr<CalibrationTable> table = CalibrationFromP0(response);
  ASSERT_THAT(table.status(), IsOk());
  const MomentImage moments = DemodulateOnePixel([&](int g, int k) {
    const double p0 = -p0_raw[g] * 0.000031 * kPi;
    return 700.0 + 90.0 * std::cos(phi[g] + 2.0 * kPi * k / 3.0 + p0);
  });
  const int64_t n = 512 * 424;
  for (int g = 0; g < 3; ++g) {
    const int j = kGroupHarmonics[g];
    const std::complex<double> z(moments.real_plane(j)[0], moments.imag_plane(j)[0]);
    const std::complex<double> k(table->real[j * n], table->imag[j * n]);  // pixel 0
    EXPECT_NEAR(std::remainder(std::arg(k * z) - phi[g], 2.0 * kPi), 0.0, 1e-5) << j;
    // Without the calibration the phase is off by p0.
    EXPECT_GT(std::abs(std::remainder(std::arg(z) - phi[g], 2.0 * kPi)), 0.05) << j;
  }
}

TEST(P0Tables, BecomeAUnitModulusPhaseCalibrationPerHarmonic) {
  std::vector<uint8_t> response(kP0ResponseBytes + 100, 0);  // a tail after the tables
  const size_t table_bytes = 2 + 2 * 512 * 424 + 2;
  auto put = [&](int g, int row, int x, uint16_t v) {
    const size_t at = 32 + g * table_bytes + 2 + 2 * (size_t(row) * 512 + x);
    response[at] = static_cast<uint8_t>(v & 0xFF);
    response[at + 1] = static_cast<uint8_t>(v >> 8);
  };
  put(0, 10, 20, 1000);
  put(1, 10, 20, 2000);
  put(2, 300, 20, 3000);
  absl::StatusOr<CalibrationTable> table = CalibrationFromP0(response);
  ASSERT_THAT(table.status(), IsOk());
  ASSERT_THAT(table->Validate(), IsOk());
  EXPECT_THAT(CheckCalibrationMatches(*table, Schedule(), ImageGeometry{512, 424}), IsOk());
  const int64_t n = 512 * 424;
  auto factor = [&](int j, int row, int x) {
    const size_t q = static_cast<size_t>(j * n + row * 512 + x);
    return std::complex<double>(table->real[q], table->imag[q]);
  };
  // k = exp(+i * v * 0.000031 * pi) = exp(-i * p0), p0 = -v * 0.000031 * pi: the rotation
  // libfreenect2 applies to its demodulated phasor.
  EXPECT_NEAR(std::arg(factor(10, 10, 20)), 1000 * 0.000031 * kPi, 1e-6);
  EXPECT_NEAR(std::arg(factor(2, 10, 20)), 2000 * 0.000031 * kPi, 1e-6);
  EXPECT_NEAR(std::remainder(std::arg(factor(15, 300, 20)) - 3000 * 0.000031 * kPi, 2 * kPi),
              0.0, 1e-6);
  EXPECT_NEAR(std::abs(factor(15, 300, 20)), 1.0, 1e-6);
  EXPECT_EQ(factor(15, 10, 20), std::complex<double>(1.0, 0.0));  // P0 = 0
  EXPECT_EQ(factor(3, 10, 20), std::complex<double>(1.0, 0.0));   // not measured

  response.resize(kP0ResponseBytes - 1);
  EXPECT_THAT(CalibrationFromP0(response).status(),
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("at least 1302572")));
}

}  // namespace
}  // namespace transient::kinect2
