// The noise-free signal formation of thesis §8.2.1 for the simulated two-tap pixel: from the
// returns of a scene to the expected differential signal (tap A - tap B, electrons) of every
// exposure of one take, and the true moments a calibrated capture should reproduce.
#pragma once

#include <vector>

#include "fixed_pattern.h"
#include "modulation.h"
#include "scene.h"
#include "transient/reconstruct/acquisition.h"
#include "transient/reconstruct/image.h"

namespace transient::sim {

// Expected signals of the exposures of one take, in electrons per exposure.
struct ExposureSignals {
  ImageGeometry geometry;
  std::vector<float> light;                      // [P] active light reaching the pixel
  std::vector<std::vector<float>> differential;  // [exposure][P] expected A - B
};

class ForwardModel {
 public:
  ForwardModel(const SimulatorOptions& options, const AcquisitionSchedule& schedule,
               FixedPattern pattern);

  // For exposure e (index into the schedule's exposures() of take 0):
  //  * modulated at frequency nu with bucket shift beta:
  //      D = gain_p * sum_r a_r * integral t(2*pi*nu*(tau + d_p) - beta) dG_r(tau),
  //    t the split effective modulation (modulation.h). Dirac returns use its table, continuous
  //    returns its Fourier series sum_h 2*Re(T_h exp(-i*h*beta) exp(i*h*2*pi*nu*d_p) phi_r(h*nu))
  //    truncated where the terms fall below 1e-9 of the return;
  //  * unmodulated with illumination: D = light (everything lands in tap A);
  //  * unmodulated without illumination: D = 0.
  // a_r is the return's amplitude times the exposure time (electrons).
  void Evaluate(const ReturnPlanes& returns, ExposureSignals* out) const;

  // c_j = scale * sum_r a_r * phi_r(2*pi*j*f), j = 0..m: the moments at the schedule's base
  // frequency without any camera error, `scale` converting electrons to output units.
  MomentImage TrueMoments(const ReturnPlanes& returns, double scale) const;

  const FixedPattern& pattern() const { return pattern_; }
  const SplitModulation& modulation() const { return modulation_; }

 private:
  struct FrequencyGroup {
    double frequency_hz;
    std::vector<int> exposures;  // indices into exposures() of take 0
  };

  void EvaluatePixel(const ReturnPlanes& returns, int64_t p, ExposureSignals* out,
                     std::vector<Complex>* scratch) const;

  ScheduleOptions schedule_;
  std::vector<ExposureConfig> exposures_;  // of take 0
  std::vector<FrequencyGroup> groups_;
  FixedPattern pattern_;
  SplitModulation modulation_;
};

}  // namespace transient::sim
