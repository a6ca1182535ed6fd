// Shot noise, read noise, full well and ADC of the simulated two-tap pixel.
#include "sensor.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <limits>

#include "kinect2/kinect2_format.h"
#include "random.h"

namespace transient::sim {

Sensor::Sensor(const SimulatorOptions& options)
    : noise_(options.noise),
      seed_(options.seed),
      ambient_e_(options.ambient * options.schedule.exposure_s),
      full_well_(options.full_well),
      read_noise_(options.read_noise),
      snr_(options.snr),
      adc_bits_(options.adc_bits),
      adc_(options.adc) {
  if (adc_ == Adc::kKinect2) {
    // Signed samples, full well at the largest companded magnitude.
    electrons_per_unit_ = full_well_ / kinect2::kMaxMagnitude;
    black_level_ = 0.0;
    saturation_level_ = kinect2::kSaturatedValue;
    max_valid_ = kinect2::kMaxMagnitude;
  } else if (adc_bits_ == 0) {
    electrons_per_unit_ = 1.0;
    black_level_ = 0.0;
    saturation_level_ = FLT_MAX;
    max_valid_ = INFINITY;
  } else {
    // A - B spans [-full_well, full_well]: the black level sits mid-scale.
    const double half_range = std::ldexp(1.0, adc_bits_ - 1);
    electrons_per_unit_ = full_well_ / half_range;
    black_level_ = half_range;
    saturation_level_ = static_cast<float>(2.0 * half_range - 1.0);
    max_valid_ = 2.0 * half_range - 2.0;
  }
}

namespace {

// What the two taps of a pixel expect to hold (electrons), from the active light reaching it
// and its differential part: tap A the light weighted by r, tap B by 1 - r, ambient light half
// in each; unmodulated, all of it in tap A.
struct Charges {
  double a, b;
};
Charges ChargesOf(double light, double difference, bool modulated, double ambient) {
  if (modulated)
    return {0.5 * (light + difference + ambient), 0.5 * (light - difference + ambient)};
  return {light + ambient, 0.0};
}

// The output of A - B = `difference` electrons: black level + difference / electrons a unit,
// through the ADC (rounded to a code, saturated outside 0..max_valid) or as a float; a full tap
// gives `saturation` either way. In plain arithmetic that vectorizes: floor(value + 0.5) by
// rounding to an integer in the last bits of 1.5 * 2^52 (exact below 2^51; above it the code
// saturates either way).
struct Digitizer {
  double black_level, scale, max_valid;
  float saturation;

  double Value(double difference) const { return black_level + difference * scale; }
  float Adc(double difference, bool full) const {
    const double half_up = Value(difference) + 0.5;
    const double rounded = (half_up + 0x1.8p52) - 0x1.8p52;
    const double code = rounded > half_up ? rounded - 1.0 : rounded;
    const bool saturated = full || code < 0.0 || code > max_valid;
    return saturated ? saturation : static_cast<float>(code);
  }
  float Float(double difference, bool full) const {
    return full ? saturation : static_cast<float>(Value(difference));
  }
};

}  // namespace

float Sensor::Output(double difference, bool full, int column, int count) const {
  const Digitizer digitizer{black_level_, 1.0 / electrons_per_unit_, max_valid_, saturation_level_};
  if (adc_ == Adc::kKinect2) {
    const bool dead = column == 0 || column == count - 1;  // the camera's unreadable columns
    return dead   ? std::numeric_limits<float>::quiet_NaN()
           : full ? saturation_level_
                  : kinect2::QuantizeSample(digitizer.Value(difference));
  }
  return adc_bits_ == 0 ? digitizer.Float(difference, full) : digitizer.Adc(difference, full);
}

void Sensor::ReadRowReference(const TapInput& input, int64_t offset, int count, uint64_t sequence,
                              int row, float* out) const {
  Random random({seed_, kStreamNoise, sequence, static_cast<uint64_t>(row)});
  const double read2 = read_noise_ * read_noise_;
  auto shot_and_read = [&](double mean, double normal) {
    if (mean >= kPoissonLimit) return mean + std::sqrt(mean + read2) * normal;
    return static_cast<double>(random.Poisson(std::max(mean, 0.0))) + read_noise_ * normal;
  };
  // Box-Muller yields normals in pairs; the second one serves the next pixel.
  double spare = 0.0;
  bool has_spare = false;
  auto normal = [&]() {
    if (has_spare) {
      has_spare = false;
      return spare;
    }
    double first;
    random.Normals(&first, &spare);
    has_spare = true;
    return first;
  };
  for (int i = 0; i < count; ++i) {
    const int64_t p = offset + i;
    const double light = input.illuminated ? input.light_gain * input.light[p] : 0.0;
    const double difference = input.illuminated ? input.light_gain * input.differential[p] : 0.0;
    const auto [a, b] = ChargesOf(light, difference, input.modulated, ambient_e_);
    // A tap whose expected charge exceeds the full well saturates (noise near the edge is
    // ignored: it only moves the edge by a fraction of a percent).
    const bool full = a > full_well_ || b > full_well_;
    double value = a - b;
    switch (noise_) {
      case NoiseModel::kPhysical: {
        if (a >= kPoissonLimit && b >= kPoissonLimit) {
          // Both taps Gaussian: their difference is one normal with the summed variance.
          value += std::sqrt(a + b + 2.0 * read2) * normal();
        } else {
          const double tap_a = shot_and_read(a, normal());  // in this order: reproducible
          value = tap_a - shot_and_read(b, normal());
        }
        break;
      }
      case NoiseModel::kGaussian:
        value += input.light_gain * input.light[p] / snr_ * normal();
        break;
      case NoiseModel::kNone:
        break;
    }
    out[i] = Output(value, full, i, count);
  }
}

namespace {

// Pixels a batch of ReadRow's normals (even: a batch ends on a whole Box-Muller pair).
constexpr int kBatch = 256;

// The next `pairs` Box-Muller pairs of `random` into normals[0, 2 pairs) in the order
// Random::Normals gives them; with `skip`, one uniform more is drawn after each pair. The
// uniforms come one after another from the stream, the transform (plain arithmetic, random.h)
// runs over all of them in vector registers.
[[gnu::always_inline]] inline void DrawNormals(Random& random, int pairs, bool skip,
                                               double* normals) {
  uint64_t first[kBatch], second[kBatch];
  for (int j = 0; j < pairs; ++j) {
    first[j] = random.Next();
    second[j] = random.Next();
    if (skip) random.Next();
  }
  for (int j = 0; j < pairs; ++j) {
    BoxMuller(1.0 - Random::UniformOf(first[j]), Random::UniformOf(second[j]), &normals[2 * j],
              &normals[2 * j + 1]);
  }
}

}  // namespace

// ReadRow's loops in vector registers of 2, 4 or 8 doubles: compiled for the baseline, AVX2 and
// AVX-512, the best this CPU runs chosen when the library loads (GCC's target_clones; the same
// bits in each, as no multiply-add is contracted). Only the baseline under Clang (the sanitizer
// build).
#if defined(__GNUC__) && !defined(__clang__)
#define TRANSIENT_SENSOR_CLONES \
  __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define TRANSIENT_SENSOR_CLONES
#endif

TRANSIENT_SENSOR_CLONES
void Sensor::ReadRow(const TapInput& input, int64_t offset, int count, uint64_t sequence, int row,
                     float* out) const {
  // Batches of the taps' charges, their noise and their output, each choice made outside the
  // loops so that they vectorize.
  double expected_a[kBatch], expected_b[kBatch], normals[2 * kBatch];
  auto charges = [&](int start, int n) {
    const float* light = input.light + offset + start;
    const float* differential = input.differential + offset + start;
    const double gain = input.light_gain, ambient = ambient_e_;
    auto each = [&](bool modulated, auto light_of, auto difference_of) {
      for (int i = 0; i < n; ++i) {
        const Charges c = ChargesOf(light_of(i), difference_of(i), modulated, ambient);
        expected_a[i] = c.a;
        expected_b[i] = c.b;
      }
    };
    if (input.illuminated) {
      each(
          input.modulated, [&](int i) { return gain * light[i]; },
          [&](int i) { return gain * differential[i]; });
    } else {
      auto none = [](int) { return 0.0; };
      each(input.modulated, none, none);
    }
  };

  // What ReadRowReference draws a pixel (its order): nothing; one normal (noise gaussian, or
  // physical with both taps Gaussian); or, for an unmodulated exposure (tap B empty) whose tap A
  // is Gaussian, a normal for each tap and tap B's Poisson(0), which draws one uniform and is 0.
  // A row with any other pixel (a tap with Poisson shot noise) goes pixel by pixel.
  bool one_normal = false;
  if (noise_ == NoiseModel::kPhysical) {
    int poisson_a = 0, poisson_b = 0;  // taps under the limit (or NaN)
    for (int start = 0; start < count; start += kBatch) {
      const int n = std::min(kBatch, count - start);
      charges(start, n);
      for (int i = 0; i < n; ++i) {
        poisson_a += !(expected_a[i] >= kPoissonLimit);
        poisson_b += !(expected_b[i] >= kPoissonLimit);
      }
    }
    one_normal = poisson_a == 0 && poisson_b == 0;
    const bool unlit_tap_b = poisson_a == 0 && !input.modulated;  // b = 0 in every pixel
    if (!one_normal && !unlit_tap_b) {
      ReadRowReference(input, offset, count, sequence, row, out);
      return;
    }
  }

  Random random({seed_, kStreamNoise, sequence, static_cast<uint64_t>(row)});
  const double read2 = read_noise_ * read_noise_, read_noise = read_noise_, snr = snr_;
  const double full_well = full_well_;
  const Digitizer digitizer{black_level_, 1.0 / electrons_per_unit_, max_valid_, saturation_level_};
  auto pixels = [&](int start, int n, auto noise, auto output) {
    for (int i = 0; i < n; ++i) {
      const double a = expected_a[i], b = expected_b[i];
      const bool full = (a > full_well) | (b > full_well);
      out[start + i] = output(noise(a, b, start + i, i), full, start + i);
    }
  };
  auto with_output = [&](int start, int n, auto noise) {
    if (adc_ == Adc::kKinect2) {
      pixels(start, n, noise,
             [&](double v, bool full, int column) { return Output(v, full, column, count); });
    } else if (adc_bits_ == 0) {
      pixels(start, n, noise, [&](double v, bool full, int) { return digitizer.Float(v, full); });
    } else {
      pixels(start, n, noise, [&](double v, bool full, int) { return digitizer.Adc(v, full); });
    }
  };
  for (int start = 0; start < count; start += kBatch) {
    const int n = std::min(kBatch, count - start);
    charges(start, n);
    if (noise_ == NoiseModel::kNone) {
      with_output(start, n, [](double a, double b, int, int) { return a - b; });
    } else if (noise_ == NoiseModel::kGaussian) {
      DrawNormals(random, (n + 1) / 2, false, normals);
      const float* light = input.light + offset;
      const double gain = input.light_gain;
      with_output(start, n, [&](double a, double b, int column, int i) {
        return (a - b) + gain * light[column] / snr * normals[i];
      });
    } else if (one_normal) {
      DrawNormals(random, (n + 1) / 2, false, normals);
      with_output(start, n, [&](double a, double b, int, int i) {
        return (a - b) + std::sqrt(a + b + 2.0 * read2) * normals[i];
      });
    } else {
      DrawNormals(random, n, true, normals);
      with_output(start, n, [&](double a, double, int, int i) {
        const double tap_a = a + std::sqrt(a + read2) * normals[2 * i];
        return tap_a - (0.0 + read_noise * normals[2 * i + 1]);  // Poisson(0) is 0
      });
    }
  }
}

}  // namespace transient::sim
