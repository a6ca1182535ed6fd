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

void Sensor::ReadRow(const TapInput& input, int64_t offset, int count, uint64_t sequence, int row,
                     float* out) const {
  Random random({seed_, kStreamNoise, sequence, static_cast<uint64_t>(row)});
  const double read2 = read_noise_ * read_noise_;
  auto shot_and_read = [&](double mean, double normal) {
    if (mean >= kPoissonLimit) return mean + std::sqrt(mean + read2) * normal;
    return static_cast<double>(random.Poisson(std::max(mean, 0.0))) + read_noise_ * normal;
  };
  const double scale = 1.0 / electrons_per_unit_;
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
    double a, b;
    if (input.modulated) {
      a = 0.5 * (light + difference + ambient_e_);
      b = 0.5 * (light - difference + ambient_e_);
    } else {
      a = light + ambient_e_;
      b = 0.0;
    }
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
    bool saturated = full;
    value = black_level_ + value * scale;
    if (adc_ == Adc::kKinect2) {
      const bool dead = i == 0 || i == count - 1;  // the camera's unreadable columns
      out[i] = dead ? std::numeric_limits<float>::quiet_NaN()
                    : saturated ? saturation_level_ : kinect2::QuantizeSample(value);
      continue;
    }
    if (adc_bits_ != 0) {
      value = std::floor(value + 0.5);
      saturated = saturated || value < 0.0 || value > max_valid_;
    }
    out[i] = saturated ? saturation_level_ : static_cast<float>(value);
  }
}

}  // namespace transient::sim
