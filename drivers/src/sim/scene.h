// What a simulated scene hands the forward model: per pixel, a few returns of its impulse
// response, each a Dirac or an exponentially modified Gaussian (EMG). Scenes are built for one
// camera (its rays) and may change with time.
#pragma once

#include <memory>
#include <vector>

#include "absl/status/statusor.h"
#include "transient/drivers/capture_source.h"
#include "transient/drivers/simulator.h"
#include "transient/reconstruct/moments.h"

namespace transient::sim {

// Returns of every pixel as planes [R, H, W]. Return r of pixel p is at index r * P + p. A
// return is a Dirac at delay tau when sigma_s = 0 and decay_rate = 0; otherwise it is the
// distribution of tau + N(0, sigma_s^2) + Exp(decay_rate) (an EMG; decay_rate = 0 means no
// exponential tail), whose characteristic function
//   E exp(i*w*t) = exp(i*w*tau - sigma^2*w^2/2) / (1 - i*w/decay_rate)
// is analytic, so moments at any frequency are closed-form. Unused entries have amplitude 0.
// Returns of one pixel are sorted by tau.
struct ReturnPlanes {
  ImageGeometry geometry;
  int max_returns = 0;
  std::vector<float> tau_s;       // delay (onset of a continuous return), s
  std::vector<float> amplitude;   // electrons per second of exposure; 0 = unused
  std::vector<float> sigma_s;     // Gaussian spread, s
  std::vector<float> decay_rate;  // 1/s; 0 = none

  void Reset(ImageGeometry g, int r);
  int64_t index(int r, int64_t p) const { return r * geometry.pixel_count() + p; }
  bool continuous(int64_t i) const { return sigma_s[i] > 0.0f || decay_rate[i] > 0.0f; }
  // Sorts the returns of every pixel by delay, unused ones last.
  void SortByDelay();
};

// E exp(i*omega*t) of return i (times 1, not times its amplitude).
Complex CharacteristicFunction(const ReturnPlanes& returns, int64_t i, double omega);

class Scene {
 public:
  virtual ~Scene() = default;
  // Returns per pixel at most.
  virtual int max_returns() const = 0;
  // Whether Render depends on the time.
  virtual bool dynamic() const { return false; }
  // The returns of every pixel at `time_s` (seconds since the capture started).
  virtual void Render(double time_s, ReturnPlanes* out) const = 0;
};

// The scene `options.scene` seen through `camera`. InvalidArgument for an unknown name.
absl::StatusOr<std::unique_ptr<Scene>> MakeScene(const SimulatorOptions& options,
                                                 const CameraInfo& camera);

// The scenes, one file each (scenes/).
std::unique_ptr<Scene> MakeMirrorsScene(const SimulatorOptions& options, const CameraInfo& camera);
std::unique_ptr<Scene> MakeCornerScene(const SimulatorOptions& options, const CameraInfo& camera);
std::unique_ptr<Scene> MakeSparseScene(const SimulatorOptions& options, const CameraInfo& camera);
std::unique_ptr<Scene> MakeVideoScene(const SimulatorOptions& options, const CameraInfo& camera);
std::unique_ptr<Scene> MakeCalibrationScene(const SimulatorOptions& options,
                                            const CameraInfo& camera);

}  // namespace transient::sim
