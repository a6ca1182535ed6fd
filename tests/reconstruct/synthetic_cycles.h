// Synthetic capture cycles with known moments, by the measurement convention of
// demodulation.h: the oracle of the demodulator's and the frame pipeline's tests.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "transient/reconstruct/acquisition.h"
#include "transient/reconstruct/image.h"
#include "transient/reconstruct/moments.h"

namespace transient::testing {

// Phase of the light the low-frequency proxy sees (returns at a few metres at 900 kHz give
// ~0.1 rad); the modulus must not care.
inline constexpr double kProxyPhase = 0.3;

AcquisitionSchedule MakeSchedule(SamplingScheme sampling, int phase_steps, ZerothScheme zeroth,
                                 int takes, int order = 3);

// Known moments and offsets of a synthetic scene: c_0 in [5, 10], |c_j| <= 0.9 c_0 with random
// phases, offsets (ambient plus dark level) in [20, 50].
struct Scene {
  ImageGeometry geometry;
  int order = 0;
  std::vector<double> c0, offset;
  std::vector<std::vector<Complex>> c;  // c[j][p], j = 0..m (c[0] unused)
};

Scene RandomScene(ImageGeometry geometry, int order, std::mt19937_64& rng);

// One raw frame of `config` by the measurement convention (demodulation.h), evaluated through
// the sub-exposures rather than through nominal_gain(): M(beta) = offset +
// sum_k w_k Re(exp(-i (beta + theta_k)) c_j); unmodulated pair: offset + c_0 and offset.
RawFrame Synthesize(const AcquisitionSchedule& schedule, const Scene& scene,
                    const ExposureConfig& config, int64_t cycle, uint64_t sequence, double sigma,
                    std::mt19937_64& rng, double scale = 1.0, double phase_slip = 0.0);

// Every exposure of one cycle, in schedule order, with Gaussian noise `sigma`.
std::vector<RawFrame> SynthesizeCycle(const AcquisitionSchedule& schedule, const Scene& scene,
                                      int64_t cycle, double sigma, std::mt19937_64& rng);

}  // namespace transient::testing
