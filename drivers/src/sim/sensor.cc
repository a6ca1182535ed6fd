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

}  // namespace

// The output of A - B = `difference` electrons: black level + difference / electrons a unit,
// through the ADC (rounded to a code, saturated outside 0..max_valid), as a float or as the
// Kinect's companded sample (NaN in the first and last column); a full tap gives `saturation`.
// In plain arithmetic that vectorizes, but for the Kinect's companding.
struct Sensor::Digitizer {
  double black_level, scale, max_valid;
  float saturation;
  Adc adc;
  bool float_output;

  double Value(double difference) const { return black_level + difference * scale; }
  float Code(double difference, bool full) const {
    const double code = Sensor::RoundHalfUp(Value(difference));
    const bool saturated = full || code < 0.0 || code > max_valid;
    return saturated ? saturation : static_cast<float>(code);
  }
  float Float(double difference, bool full) const {
    return full ? saturation : static_cast<float>(Value(difference));
  }
  float Kinect(double difference, bool full, int column, int count) const {
    const bool dead = column == 0 || column == count - 1;  // the camera's unreadable columns
    return dead   ? std::numeric_limits<float>::quiet_NaN()
           : full ? saturation
                  : kinect2::QuantizeSample(Value(difference));
  }
  float Output(double difference, bool full, int column, int count) const {
    if (adc == Adc::kKinect2) return Kinect(difference, full, column, count);
    return float_output ? Float(difference, full) : Code(difference, full);
  }
};

Sensor::Digitizer Sensor::MakeDigitizer() const {
  return {black_level_,  1.0 / electrons_per_unit_, max_valid_, saturation_level_, adc_,
          adc_bits_ == 0};
}

float Sensor::Output(double difference, bool full, int column, int count) const {
  return MakeDigitizer().Output(difference, full, column, count);
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

// The taps' charges (ChargesOf) of pixels [first, first + n) into a[] and b[], n <= kBatch,
// the choice of light made outside the loop: a load under `illuminated ? ... : 0.0` kept it
// scalar.
[[gnu::always_inline]] inline void BatchCharges(const TapInput& input, int64_t first, int n,
                                                double ambient, double* a, double* b) {
  const float* light = input.light + first;
  const float* differential = input.differential + first;
  const double gain = input.light_gain;
  auto each = [&](auto light_of, auto difference_of) {
    for (int i = 0; i < n; ++i) {
      const Charges c = ChargesOf(light_of(i), difference_of(i), input.modulated, ambient);
      a[i] = c.a;
      b[i] = c.b;
    }
  };
  if (input.illuminated) {
    each([&](int i) { return gain * light[i]; }, [&](int i) { return gain * differential[i]; });
  } else {
    auto none = [](int) { return 0.0; };
    each(none, none);
  }
}

// The taps of pixels [offset, offset + count) under the Poisson limit (or NaN), in vector
// registers as ReadBatches' loops (below). (A struct of its own: Clang 15 left a std::pair's
// constructor undefined in the clones.)
struct PoissonCounts {
  int a, b;
};
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) PoissonCounts
PoissonTaps(const TapInput& input, int64_t offset, int count, double ambient) {
  int poisson_a = 0, poisson_b = 0;
  double a[kBatch], b[kBatch];
  for (int start = 0; start < count; start += kBatch) {
    const int n = std::min(kBatch, count - start);
    BatchCharges(input, offset + start, n, ambient, a, b);
    for (int i = 0; i < n; ++i) {
      poisson_a += !(a[i] >= Sensor::kPoissonLimit);
      poisson_b += !(b[i] >= Sensor::kPoissonLimit);
    }
  }
  return PoissonCounts{poisson_a, poisson_b};
}

}  // namespace

Sensor::Draws Sensor::RowDraws(const TapInput& input, int64_t offset, int count) const {
  switch (noise_) {
    case NoiseModel::kNone:
      return Draws::kNothing;
    case NoiseModel::kGaussian:
      return Draws::kOneNormal;
    case NoiseModel::kPhysical:
      break;
  }
  const PoissonCounts poisson = PoissonTaps(input, offset, count, ambient_e_);
  if (poisson.a == 0 && poisson.b == 0) return Draws::kOneNormal;
  if (poisson.a == 0 && !input.modulated) return Draws::kUnlitTapB;  // b = 0 in every pixel
  return Draws::kPixelByPixel;
}

namespace {

// What ReadRow's loops take of the sensor and the row.
struct RowBatches {
  const TapInput& input;
  int64_t offset;
  int count;
  Sensor::Draws draws;
  bool gaussian;  // noise = gaussian (else physical or none)
  double ambient, read_noise, snr, full_well;
};

// ReadRow's loops in vector registers of 8, 4 or 2 doubles: compiled for AVX-512, AVX2 and the
// baseline, the best this CPU runs chosen when the library loads (target_clones, as the density
// kernel's DensityOrbits; a file-local function, which GCC and Clang both clone). The same bits
// in each clone, as no multiply-add is fused (sensor.cc is compiled with -ffp-contract=off). The
// lambdas are inlined into each clone.
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void ReadBatches(
    const RowBatches& row, const Sensor::Digitizer& digitizer_of_sensor, Random& random,
    float* out) {
  // Copies: a store to `out` could otherwise change what the loops read through references.
  const Sensor::Digitizer digitizer = digitizer_of_sensor;
  const TapInput& input = row.input;
  const double read2 = row.read_noise * row.read_noise, read_noise = row.read_noise;
  const double snr = row.snr, full_well = row.full_well;
  double expected_a[kBatch], expected_b[kBatch], normals[2 * kBatch];
  auto pixels = [&](int start, int n, auto noise, auto output) {
    for (int i = 0; i < n; ++i) {
      const double a = expected_a[i], b = expected_b[i];
      const bool full = (a > full_well) | (b > full_well);
      out[start + i] = output(noise(a, b, start + i, i), full, start + i);
    }
  };
  auto with_output = [&](int start, int n, auto noise) {
    if (digitizer.adc == Adc::kKinect2) {
      pixels(start, n, noise, [&](double v, bool full, int column) {
        return digitizer.Kinect(v, full, column, row.count);
      });
    } else if (digitizer.float_output) {
      pixels(start, n, noise, [&](double v, bool full, int) { return digitizer.Float(v, full); });
    } else {
      pixels(start, n, noise, [&](double v, bool full, int) { return digitizer.Code(v, full); });
    }
  };
  for (int start = 0; start < row.count; start += kBatch) {
    const int n = std::min(kBatch, row.count - start);
    BatchCharges(input, row.offset + start, n, row.ambient, expected_a, expected_b);
    if (row.draws == Sensor::Draws::kNothing) {
      with_output(start, n, [](double a, double b, int, int) { return a - b; });
    } else if (row.gaussian) {
      DrawNormals(random, (n + 1) / 2, false, normals);
      const float* light = input.light + row.offset;
      const double gain = input.light_gain;
      with_output(start, n, [&](double a, double b, int column, int i) {
        return (a - b) + gain * light[column] / snr * normals[i];
      });
    } else if (row.draws == Sensor::Draws::kOneNormal) {
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

}  // namespace

void Sensor::ReadRow(const TapInput& input, int64_t offset, int count, uint64_t sequence, int row,
                     float* out) const {
  const Draws draws = RowDraws(input, offset, count);
  if (draws == Draws::kPixelByPixel) {
    ReadRowReference(input, offset, count, sequence, row, out);
    return;
  }
  Random random({seed_, kStreamNoise, sequence, static_cast<uint64_t>(row)});
  ReadBatches(RowBatches{input, offset, count, draws, noise_ == NoiseModel::kGaussian, ambient_e_,
                         read_noise_, snr_, full_well_},
              MakeDigitizer(), random, out);
}

}  // namespace transient::sim
