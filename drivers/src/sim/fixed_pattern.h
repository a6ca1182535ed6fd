// The fixed-pattern errors of one simulated camera unit: per-pixel demodulation contrast
// (gain) and modulation delay. They belong to the camera (camera_seed), never to the scene, so
// a calibration measured on `sim:calibration` corrects `sim:mirrors` taken with the same
// camera_seed. Both act on modulated exposures only, which the per-pixel, per-harmonic factors
// of thesis §8.3.2 remove (a gain g and delay d turn c_j into g*exp(i*2*pi*j*f*d)*c_j for the
// sinusoid).
#pragma once

#include <vector>

#include "transient/drivers/simulator.h"
#include "transient/reconstruct/image.h"

namespace transient::sim {

struct FixedPattern {
  ImageGeometry geometry;
  std::vector<float> gain;      // demodulation contrast, 1 + gain_error * N(0, 1) in [0.5, 1.5]
  std::vector<double> delay_s;  // delay_ns + delay_error_ns * (sqrt(3/2) * ramp + sqrt(1/2) *
                                // N(0, 1)), ramp from -1 (left column) to 1 (right column), so
                                // half the variance is a column gradient and half random; seconds
};

FixedPattern MakeFixedPattern(const SimulatorOptions& options);

}  // namespace transient::sim
