// The impulse responses of a simulated scene as closed-form returns (the simulator's ground
// truth before any sensor effect), for benchmarks that need moments at arbitrary frequencies
// and the true distribution of times of flight: `transient eval` (thesis fig. 8.13).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "transient/drivers/capture_source.h"
#include "transient/drivers/simulator.h"
#include "transient/reconstruct/moments.h"

namespace transient {

// One return of a pixel's impulse response: a Dirac at tau_s when sigma_s = 0 and
// decay_rate = 0; otherwise the distribution of tau_s + N(0, sigma_s^2) + Exp(decay_rate), an
// exponentially modified Gaussian (EMG; decay_rate = 0: no exponential tail, sigma_s = 0: no
// Gaussian spread). tau_s is a round-trip time of flight in seconds.
struct SceneReturn {
  double tau_s = 0.0;
  double amplitude = 0.0;   // total light of the return (electrons per second of exposure), > 0
  double sigma_s = 0.0;     // s, >= 0
  double decay_rate = 0.0;  // 1/s, >= 0; 0 = none
};

// E exp(i*omega*t) of one return (times 1, not times its amplitude), closed form:
//   exp(i*omega*tau - sigma^2*omega^2/2) / (1 - i*omega/decay_rate).
Complex SceneReturnCharacteristicFunction(const SceneReturn& r, double omega);

// The returns of every pixel of a simulated scene at one time, seen through the simulator's
// camera for the same options.
struct SceneReturns {
  CameraInfo camera;                 // intrinsics of the simulated camera (pinhole, no distortion)
  std::vector<SceneReturn> returns;  // all pixels' returns, pixel after pixel, each sorted by tau
  std::vector<int64_t> offsets;      // pixel p owns returns[offsets[p], offsets[p + 1])

  std::span<const SceneReturn> pixel(int64_t p) const {
    return std::span<const SceneReturn>(returns).subspan(offsets[p], offsets[p + 1] - offsets[p]);
  }
};

// Renders `options.scene` at `time_s` (seconds since the capture started). InvalidArgument when
// `options` fails SimulatorOptions::Validate() or time_s is negative or not finite.
[[nodiscard]] absl::StatusOr<SceneReturns> RenderSceneReturns(const SimulatorOptions& options,
                                                              double time_s = 0.0);

// Unit direction (x right, y down, z forward) of the ray through the centre of pixel (u, v) of
// `camera`: what the simulator's scenes intersect with their geometry.
std::array<double, 3> CameraRay(const CameraInfo& camera, int u, int v);

}  // namespace transient
