// Helpers of the simulator tests: open a source by URI, capture whole cycles and demodulate
// them the way the demodulator contract of simulator.h says (four-bucket phasor / nominal gain).
#pragma once

#include <memory>
#include <vector>

#include "absl/strings/string_view.h"
#include "transient/drivers/capture_source.h"
#include "transient/reconstruct/moments.h"

namespace transient::sim::testing {

// Opens "sim:..." through the scheme's opener; fails the test (and returns null) when refused.
std::unique_ptr<CaptureSource> OpenOrDie(absl::string_view uri);

// The raw frames of the next whole cycle (started source).
std::vector<RawFrame> CaptureCycle(CaptureSource& source);

// Per pixel, c_0..c_m of one cycle (take 0): c_j = Z_j / nominal_gain with
// Z = (M(0) - M(pi))/2 + i*(M(pi/2) - M(3*pi/2))/2; c_0 = on - off for the pair, |Z/g| at the
// proxy frequency. Indexed [j][p].
std::vector<std::vector<Complex>> Demodulate(const std::vector<RawFrame>& cycle,
                                             const AcquisitionSchedule& schedule);

// Per-pixel calibration factors k_j = c_0 / c_j from a Dirac at zero (thesis §8.3.2), and their
// application (indexed like Demodulate).
std::vector<std::vector<Complex>> CalibrationFactors(
    const std::vector<std::vector<Complex>>& dirac);
void ApplyFactors(const std::vector<std::vector<Complex>>& factors,
                  std::vector<std::vector<Complex>>* moments);

// The true moment j of pixel p.
Complex TrueMoment(const GroundTruth& truth, int j, int64_t p);

}  // namespace transient::sim::testing
