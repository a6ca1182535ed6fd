// Per-pixel gain and delay errors drawn from the camera seed alone.
#include "fixed_pattern.h"

#include <algorithm>
#include <cmath>

#include "random.h"

namespace transient::sim {

FixedPattern MakeFixedPattern(const SimulatorOptions& options) {
  FixedPattern pattern;
  const ImageGeometry g{options.width, options.height};
  pattern.geometry = g;
  pattern.gain.resize(g.pixel_count());
  pattern.delay_s.resize(g.pixel_count());
  Random random({options.camera_seed, kStreamFixedPattern});
  const double ramp_weight = std::sqrt(1.5), noise_weight = std::sqrt(0.5);
  for (int v = 0; v < g.height; ++v) {
    for (int u = 0; u < g.width; ++u) {
      const int64_t p = int64_t{v} * g.width + u;
      double gain_noise, delay_noise;
      random.Normals(&gain_noise, &delay_noise);  // drawn even when unused: same pattern
      pattern.gain[p] =
          static_cast<float>(std::clamp(1.0 + options.gain_error * gain_noise, 0.5, 1.5));
      const double ramp = g.width > 1 ? 2.0 * u / (g.width - 1) - 1.0 : 0.0;
      pattern.delay_s[p] =
          1e-9 * (options.delay_ns +
                  options.delay_error_ns * (ramp_weight * ramp + noise_weight * delay_noise));
    }
  }
  return pattern;
}

}  // namespace transient::sim
