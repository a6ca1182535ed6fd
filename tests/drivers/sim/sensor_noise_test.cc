// Sensor effects of the simulator: noise statistics, reproducibility, outliers, saturation.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

#include "absl/strings/str_cat.h"
#include "sim/random.h"
#include "sim/sensor.h"
#include "tests/drivers/sim/sim_test_util.h"
#include "transient/drivers/simulator.h"

namespace transient::sim::testing {
namespace {

constexpr absl::string_view kSmall = "pace=fast&width=16&height=12";

// Frames of `cycles` cycles, as [cycle][exposure].
std::vector<std::vector<RawFrame>> Capture(absl::string_view uri, int cycles) {
  auto source = OpenOrDie(uri);
  std::vector<std::vector<RawFrame>> frames;
  if (source == nullptr || !source->Start().ok()) return frames;
  for (int c = 0; c < cycles; ++c) frames.push_back(CaptureCycle(*source));
  return frames;
}

TEST(SensorNoise, StdOfAStaticPixelMatchesShotAndReadNoise) {
  // Float output in electrons. Every exposure of a pixel holds light + ambient electrons in its
  // two taps together (the noise-free "on" frame), so var(A - B) = on + 2 * read_noise^2.
  constexpr double kReadNoise = 20.0;
  constexpr int kCycles = 400;
  // 192 pixels x 399 degrees of freedom: the pooled variance ratio has a std of 0.5 %.
  constexpr double kVarianceTolerance = 0.03;
  const std::string settings =
      absl::StrCat(kSmall, "&adc_bits=0&read_noise=", kReadNoise, "&scheme=four-bucket");
  const auto expected = Capture(absl::StrCat("sim:calibration?noise=none&", settings), 1);
  const auto noisy = Capture(absl::StrCat("sim:calibration?noise=physical&", settings), kCycles);
  ASSERT_EQ(noisy.size(), static_cast<size_t>(kCycles));
  for (int e : {0, 3, 6}) {  // the "on" frame and two buckets
    double ratio_sum = 0.0;
    const int64_t count = expected[0][e].geometry.pixel_count();
    for (int64_t p = 0; p < count; ++p) {
      double mean = 0.0, square = 0.0;
      for (const auto& cycle : noisy) mean += cycle[e].pixels[p];
      mean /= kCycles;
      for (const auto& cycle : noisy) square += std::pow(cycle[e].pixels[p] - mean, 2);
      const double variance = square / (kCycles - 1);
      const double model = expected[0][0].pixels[p] + 2.0 * kReadNoise * kReadNoise;
      ratio_sum += variance / model;
      EXPECT_NEAR(mean, expected[0][e].pixels[p], 5.0 * std::sqrt(model / kCycles));
    }
    EXPECT_NEAR(ratio_sum / count, 1.0, kVarianceTolerance) << "exposure " << e;
  }
}

TEST(SensorNoise, GaussianNoiseHasStdSignalOverSnr) {
  constexpr double kSnr = 50.0;
  constexpr int kCycles = 300;
  constexpr double kStdTolerance = 0.03;
  const std::string settings = absl::StrCat(kSmall, "&adc_bits=0&scheme=four-bucket");
  const auto expected = Capture(absl::StrCat("sim:calibration?noise=none&", settings), 1);
  const auto noisy =
      Capture(absl::StrCat("sim:calibration?noise=gaussian&snr=", kSnr, "&", settings), kCycles);
  const int e = 4;
  double ratio_sum = 0.0;
  const int64_t count = expected[0][e].geometry.pixel_count();
  for (int64_t p = 0; p < count; ++p) {
    double square = 0.0;
    for (const auto& cycle : noisy)
      square += std::pow(cycle[e].pixels[p] - expected[0][e].pixels[p], 2);
    const double light = expected[0][0].pixels[p] - expected[0][1].pixels[p];  // on - off
    ratio_sum += std::sqrt(square / kCycles) / (light / kSnr);
  }
  EXPECT_NEAR(ratio_sum / count, 1.0, kStdTolerance);
}

TEST(SensorNoise, SameSeedGivesIdenticalFramesAndAnotherSeedOtherNoise) {
  const auto a = Capture(absl::StrCat("sim:mirrors?seed=5&", kSmall), 2);
  const auto b = Capture(absl::StrCat("sim:mirrors?seed=5&", kSmall), 2);
  const auto c = Capture(absl::StrCat("sim:mirrors?seed=6&", kSmall), 2);
  int differing = 0;
  for (size_t k = 0; k < a.size(); ++k) {
    for (size_t e = 0; e < a[k].size(); ++e) {
      EXPECT_EQ(a[k][e].pixels, b[k][e].pixels);
      differing += a[k][e].pixels != c[k][e].pixels;
    }
  }
  EXPECT_EQ(differing, 2 * 14);
}

TEST(SensorNoise, NoiseFreeFramesRepeatEveryCycle) {
  const auto frames = Capture(absl::StrCat("sim:mirrors?noise=none&", kSmall), 3);
  for (size_t e = 0; e < frames[0].size(); ++e) EXPECT_EQ(frames[0][e].pixels, frames[2][e].pixels);
}

// Frames of a capture that differ from the outlier-free capture of the same options.
int CountOutliers(absl::string_view settings, double rate, int cycles) {
  const auto clean = Capture(absl::StrCat("sim:mirrors?noise=none&", settings), 1);
  const auto frames =
      Capture(absl::StrCat("sim:mirrors?noise=none&outliers=", rate, "&", settings), cycles);
  int outliers = 0;
  for (const auto& cycle : frames) {
    for (size_t e = 0; e < cycle.size(); ++e) outliers += cycle[e].pixels != clean[0][e].pixels;
  }
  return outliers;
}

TEST(SensorNoise, OutlierFramesAppearAtTheConfiguredRate) {
  constexpr double kRate = 0.08;
  constexpr int kCycles = 150;  // 2100 frames
  const double n = 14.0 * kCycles;
  const double tolerance = 4.0 * std::sqrt(n * kRate * (1.0 - kRate));  // binomial, 4 sigma
  EXPECT_NEAR(CountOutliers(kSmall, kRate, kCycles), n * kRate, tolerance);
  EXPECT_EQ(CountOutliers(kSmall, 0.0, 20), 0);
}

TEST(SensorNoise, OutlierFramesDifferSignificantly) {
  // Every frame an outlier: each one is off by more than 10 % of the light somewhere.
  const auto clean = Capture(absl::StrCat("sim:mirrors?noise=none&adc_bits=0&", kSmall), 1);
  const auto slipped =
      Capture(absl::StrCat("sim:mirrors?noise=none&adc_bits=0&outliers=1&", kSmall), 1);
  for (size_t e = 0; e < clean[0].size(); ++e) {
    double worst = 0.0, light = 0.0;
    for (size_t p = 0; p < clean[0][e].pixels.size(); ++p) {
      worst = std::max(
          worst, static_cast<double>(std::abs(slipped[0][e].pixels[p] - clean[0][e].pixels[p])));
      light = std::max(light, static_cast<double>(clean[0][0].pixels[p] - clean[0][1].pixels[p]));
    }
    EXPECT_GT(worst, 0.1 * light) << "exposure " << e;
  }
}

TEST(SensorNoise, SaturatedPixelsCarryTheSaturationLevel) {
  const auto bright = Capture(absl::StrCat("sim:mirrors?brightness=1e10&", kSmall), 1);
  const auto normal = Capture(absl::StrCat("sim:mirrors?", kSmall), 1);
  for (size_t e = 0; e < bright[0].size(); ++e) {
    const RawFrame& frame = bright[0][e];
    EXPECT_EQ(frame.saturation_level, 4095.0f);
    int saturated = 0;
    for (float v : frame.pixels) saturated += v >= frame.saturation_level;
    // The dark frame holds ambient light only.
    if (frame.config.illumination) {
      EXPECT_EQ(saturated, static_cast<int>(frame.pixels.size())) << "exposure " << e;
    } else {
      EXPECT_EQ(saturated, 0);
    }
    for (float v : normal[0][e].pixels) {
      EXPECT_LT(v, normal[0][e].saturation_level);
      EXPECT_GE(v, 0.0f);
      EXPECT_EQ(v, std::floor(v)) << "12-bit ADC codes are integers";
    }
  }
}

TEST(SensorNoise, FloatOutputMarksFullTapsToo) {
  const auto bright =
      Capture(absl::StrCat("sim:calibration?adc_bits=0&brightness=1e10&", kSmall), 1);
  EXPECT_EQ(bright[0][0].pixels[0], bright[0][0].saturation_level);
  EXPECT_TRUE(std::isfinite(bright[0][0].saturation_level));
}

// A row of test light for ReadRow (electrons per exposure): bright pixels of every phase, and
// variants with a dark pixel, a NaN and a negative value.
struct TestRow {
  std::vector<float> light, differential;
};
TestRow MakeRow(int width, int odd_pixel, float odd_value) {
  TestRow row{std::vector<float>(width), std::vector<float>(width)};
  for (int i = 0; i < width; ++i) {
    row.light[i] = 50.0f + 30000.0f * static_cast<float>(i % 97) / 97.0f;
    row.differential[i] = row.light[i] * std::sin(0.37f * static_cast<float>(i));
  }
  if (odd_pixel >= 0) {
    row.light[odd_pixel] = odd_value;
    row.differential[odd_pixel] = 0.0f;
  }
  return row;
}

// ReadRow draws a row's normals in batches and transforms them in vector registers, in the
// clone of its loops this CPU runs; its reference draws each as a pixel needs it. Every draw
// pattern (RowDraws, asserted, so that the batches do run), every output (12-bit ADC, float,
// the Kinect's companded samples with their dead columns), lit and unlit exposures, an outlier's
// gain, rows at an offset into their frame, shorter and longer than a batch of 256 and of odd
// length, and rows with a dark pixel, a NaN or a negative light (pixel by pixel): the same bits.
TEST(SensorNoise, ReadRowIsItsReferenceBitForBit) {
  constexpr int kOffset = 13;                // the row starts inside its frame's planes
  constexpr int kPlane = kOffset + 601 + 5;  // room for the longest row
  const TestRow bright = MakeRow(kPlane, -1, 0.0f);
  // Each variant's odd pixel inside every row length tried but 1 and 7.
  const TestRow dark = MakeRow(kPlane, kOffset + 200, 0.0f);  // with ambient=0: under the limit
  const TestRow nan = MakeRow(kPlane, kOffset + 200, std::nanf(""));
  const TestRow negative = MakeRow(kPlane, kOffset + 200, -500.0f);
  using Draws = Sensor::Draws;
  struct Case {
    const char* settings;
    Draws bright_modulated, bright_unmodulated, dark_row;
  };
  const Case cases[] = {
      {"", Draws::kOneNormal, Draws::kUnlitTapB, Draws::kOneNormal},  // ambient keeps it lit
      {"&adc_bits=0", Draws::kOneNormal, Draws::kUnlitTapB, Draws::kOneNormal},
      {"&camera=kinect2", Draws::kOneNormal, Draws::kUnlitTapB, Draws::kOneNormal},
      {"&camera=kinect2&noise=gaussian", Draws::kOneNormal, Draws::kOneNormal, Draws::kOneNormal},
      {"&camera=kinect2&noise=none", Draws::kNothing, Draws::kNothing, Draws::kNothing},
      {"&noise=gaussian", Draws::kOneNormal, Draws::kOneNormal, Draws::kOneNormal},
      {"&noise=none", Draws::kNothing, Draws::kNothing, Draws::kNothing},
      // Without ambient light, tap A of a pixel whose light is nearly all in its differential
      // part (its phase near pi) holds under the limit: the modulated rows go pixel by pixel.
      {"&ambient=0", Draws::kPixelByPixel, Draws::kUnlitTapB, Draws::kPixelByPixel},
      {"&ambient=0&adc_bits=0", Draws::kPixelByPixel, Draws::kUnlitTapB, Draws::kPixelByPixel},
  };
  int rows = 0, batched = 0;
  for (const Case& c : cases) {
    auto options = ParseSimulatorUri(absl::StrCat("sim:mirrors?", c.settings));
    ASSERT_TRUE(options.ok()) << options.status();
    const Sensor sensor(*options);
    for (const TestRow* light : {&bright, &dark, &nan, &negative}) {
      for (bool modulated : {true, false}) {
        for (bool illuminated : {true, false}) {
          for (double gain : {1.0, 1.3}) {
            TapInput input;
            input.modulated = modulated;
            input.illuminated = illuminated;
            input.light_gain = gain;
            input.light = light->light.data();
            input.differential = light->differential.data();
            for (int count : {601, 512, 257, 256, 7, 1}) {
              const std::string what =
                  absl::StrCat(c.settings, modulated ? " modulated" : " unmodulated",
                               illuminated ? "" : " unlit", " gain ", gain, " width ", count,
                               light == &bright ? "" : " with an odd pixel");
              const Draws draws = sensor.RowDraws(input, kOffset, count);
              if (light == &bright && illuminated) {
                EXPECT_EQ(draws, modulated ? c.bright_modulated : c.bright_unmodulated) << what;
              }
              if (light == &dark && illuminated && modulated && count > 7) {
                EXPECT_EQ(draws, c.dark_row) << what;
              }
              if ((light == &nan || light == &negative) && illuminated && count > 7 &&
                  c.bright_modulated != Draws::kNothing &&
                  std::string_view(c.settings).find("gaussian") == std::string_view::npos) {
                EXPECT_EQ(draws, Draws::kPixelByPixel) << what;
              }
              batched += draws != Draws::kPixelByPixel;
              std::vector<float> fast(count), reference(count);
              sensor.ReadRow(input, kOffset, count, /*sequence=*/11, /*row=*/3, fast.data());
              sensor.ReadRowReference(input, kOffset, count, 11, 3, reference.data());
              for (int i = 0; i < count; ++i) {
                ASSERT_EQ(std::bit_cast<uint32_t>(fast[i]), std::bit_cast<uint32_t>(reference[i]))
                    << what << ", column " << i << ": " << fast[i] << " against " << reference[i];
              }
              ++rows;
            }
          }
        }
      }
    }
  }
  EXPECT_EQ(rows, 9 * 4 * 2 * 2 * 2 * 6);
  EXPECT_GT(batched, rows / 2);
}

// The ADC's rounding in plain arithmetic is floor(value + 0.5) wherever a code can be valid,
// halves and negatives included, and passes infinities and NaN through.
TEST(SensorNoise, RoundHalfUpIsFloorOfValuePlusAHalf) {
  for (double value :
       {0.0, -0.0, 0.5, -0.5, 1.5, 2.5, -1.5, 0.49999999999999994, 4095.5, 4094.4999999999995,
        65534.5, -1e-300, 1e-300, 123456.75, -7.25, 0x1p51 - 0.5, -0x1p51 + 0.5, 0x1p51 - 1.0}) {
    EXPECT_EQ(Sensor::RoundHalfUp(value), std::floor(value + 0.5)) << value;
  }
  Random random({9});
  for (int i = 0; i < 100000; ++i) {
    const double value = random.Uniform(-70000.0, 70000.0);
    ASSERT_EQ(Sensor::RoundHalfUp(value), std::floor(value + 0.5)) << value;
  }
  // Beyond 2^51 within 1 of it: far outside any ADC's codes, which saturate there either way.
  for (double value : {0x1p51 + 0.5, 0x1p52 + 1.0, -0x1p53, 1e300, -1e300}) {
    EXPECT_LE(std::abs(Sensor::RoundHalfUp(value) - std::floor(value + 0.5)), 1.0) << value;
  }
  EXPECT_EQ(Sensor::RoundHalfUp(INFINITY), INFINITY);
  EXPECT_EQ(Sensor::RoundHalfUp(-INFINITY), -INFINITY);
  EXPECT_TRUE(std::isnan(Sensor::RoundHalfUp(NAN)));
}

// The simulator's Box-Muller in plain arithmetic against the C library's log, sin and cos.
TEST(SensorNoise, BoxMullersLogarithmAndSinesAreTheLibrarys) {
  // Within a unit in the last place of the logarithm (measured: at most 1.00 over 2e7 draws).
  constexpr double kLogRelative = 2.3e-16;
  // sin and cos of 2 pi u: the C library's argument, 2 pi u rounded to a double, is itself off
  // by up to 4.4e-16 rad (measured: at most 7.3e-16 apart over 2e7 draws).
  constexpr double kSineAbsolute = 1e-15;
  Random random({7, 8});
  for (int i = 0; i < 200000; ++i) {
    const double u1 = 1.0 - random.Uniform(), u2 = random.Uniform();
    const double log = std::log(u1);
    ASSERT_NEAR(LogOfUnit(u1), log, kLogRelative * std::abs(log)) << u1;
    double sine, cosine;
    SinCosOfTurns(u2, &sine, &cosine);
    ASSERT_NEAR(sine, std::sin(2.0 * std::numbers::pi * u2), kSineAbsolute) << u2;
    ASSERT_NEAR(cosine, std::cos(2.0 * std::numbers::pi * u2), kSineAbsolute) << u2;
  }
  for (double x : {1.0, 0.5, std::numbers::sqrt2 / 2.0,
                   std::nextafter(std::numbers::sqrt2 / 2.0, 1.0), 0x1p-53, 0x1p-1022}) {
    EXPECT_NEAR(LogOfUnit(x), std::log(x), kLogRelative * std::abs(std::log(x))) << x;
  }
  // Quarter turns exactly; eighths (where rint(4u) rounds a tie) and 1 as the library.
  for (const auto& [u, sine, cosine] :
       {std::tuple{0.0, 0.0, 1.0}, {0.25, 1.0, 0.0}, {0.5, 0.0, -1.0}, {0.75, -1.0, 0.0}}) {
    double s, c;
    SinCosOfTurns(u, &s, &c);
    EXPECT_EQ(s, sine) << u;
    EXPECT_EQ(c, cosine) << u;
  }
  for (double u : {0.125, 0.375, 0.625, 0.875, 1.0}) {
    double s, c;
    SinCosOfTurns(u, &s, &c);
    EXPECT_NEAR(s, std::sin(2.0 * std::numbers::pi * u), kSineAbsolute) << u;
    EXPECT_NEAR(c, std::cos(2.0 * std::numbers::pi * u), kSineAbsolute) << u;
  }
}

}  // namespace
}  // namespace transient::sim::testing
