// The simulated two-tap (differential) pixel and its read-out, like pmd and Kinect sensors:
// tap A integrates the light weighted by the sensor modulation r, tap B by 1 - r; the raw value
// is A - B above an ADC black level. Ambient light lands half in each tap of a modulated
// exposure (it cancels in A - B but adds shot noise) and wholly in tap A of an unmodulated
// one, like the active light, so the zeroth-moment pair's difference is the active light.
#pragma once

#include <cstdint>

#include "transient/drivers/simulator.h"

namespace transient::sim {

// What one raw exposure integrates, per pixel (electrons).
struct TapInput {
  const float* differential = nullptr;  // expected A - B from the active light
  const float* light = nullptr;         // active light reaching the pixel (both taps)
  bool modulated = true;
  bool illuminated = true;
  double light_gain = 1.0;  // scales the active light (the gain jump of an outlier frame)
};

class Sensor {
 public:
  explicit Sensor(const SimulatorOptions& options);

  // Output value = black_level() + (A - B) / electrons_per_unit(): ADC counts (DN), or
  // electrons with black level 0 for adc_bits = 0; for adc = kinect2 signed companded samples
  // (black level 0), NaN in the first and last column.
  double electrons_per_unit() const { return electrons_per_unit_; }
  double black_level() const { return black_level_; }
  // The value of a saturated pixel (a tap whose expected charge exceeds the full well, or the
  // ADC clipping): the highest ADC code, or FLT_MAX for float output. Valid values stay below.
  float saturation_level() const { return saturation_level_; }

  // One raw frame of `count` pixels into `out`. The noise of row `row` of frame `sequence`
  // comes from its own random stream, so frames are reproducible from the seed alone.
  //  physical: each tap gets Poisson shot noise and Gaussian read noise; where both taps hold
  //            at least kPoissonLimit electrons the shot noise is Gaussian with the same
  //            variance, and A - B gets one normal of variance A + B + 2 * read_noise^2;
  //  gaussian: A - B gets Gaussian noise of std light / snr (thesis fig. 8.12);
  //  none:     expected values.
  //  The noise is drawn in batches and its normals transformed in vector registers wherever a
  //  row draws the same each pixel (RowDraws: every row of the usual exposures); others go
  //  pixel by pixel (ReadRowReference). Both give the same values from the same stream.
  void ReadRow(const TapInput& input, int64_t offset, int count, uint64_t sequence, int row,
               float* out) const;
  // The same pixel by pixel, drawing each number as it is needed, in the order of the code
  // before the batches (2026-12-06): the reference ReadRow is tested against. It shares the
  // taps' charges, the Box-Muller transform (random.h) and the ADC's rounding (RoundHalfUp)
  // with ReadRow; those are tested on their own.
  void ReadRowReference(const TapInput& input, int64_t offset, int count, uint64_t sequence,
                        int row, float* out) const;

  // What ReadRowReference draws for each pixel of a row, in its order:
  enum class Draws {
    kNothing,       // noise none
    kOneNormal,     // noise gaussian, or physical with both taps above kPoissonLimit
    kUnlitTapB,     // physical, unmodulated (tap B empty), tap A above the limit: a normal for
                    // each tap, then tap B's Poisson(0), which draws one uniform and is 0
    kPixelByPixel,  // any other (a tap with Poisson shot noise, or NaN)
  };
  // The same for every pixel of the row (ReadRow draws it in batches), or kPixelByPixel.
  Draws RowDraws(const TapInput& input, int64_t offset, int count) const;

  // floor(value + 0.5), the ADC's rounding, in plain arithmetic that vectorizes: rounded to an
  // integer in the last bits of 1.5 * 2^52 (round to nearest), then one less where that went up.
  // Exact for |value| < 2^51; beyond, within 1 of it (the ADC saturates there either way), and
  // infinities and NaN pass through.
  static double RoundHalfUp(double value) {
    const double half_up = value + 0.5;
    const double rounded = (half_up + 0x1.8p52) - 0x1.8p52;
    return rounded > half_up ? rounded - 1.0 : rounded;
  }

  static constexpr double kPoissonLimit = 20.0;

  // The output's constants and arithmetic (sensor.cc), which ReadRow's loops share.
  struct Digitizer;

 private:
  // A - B (electrons, with noise) of the pixel in column `column` of `count` as output.
  float Output(double difference, bool full, int column, int count) const;
  Digitizer MakeDigitizer() const;

  NoiseModel noise_;
  uint64_t seed_;
  double ambient_e_;  // electrons per exposure
  double full_well_, read_noise_, snr_;
  int adc_bits_;
  Adc adc_;
  double electrons_per_unit_, black_level_;
  float saturation_level_;
  double max_valid_;  // the largest valid ADC code
};

}  // namespace transient::sim
