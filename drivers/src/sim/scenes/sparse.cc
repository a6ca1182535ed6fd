// The `sparse` scene: k random Dirac returns per pixel, a known answer for sparse
// reconstructions (thesis §8.4.1, Pisarenko).
#include <algorithm>
#include <memory>

#include "../random.h"
#include "../scene.h"

namespace transient::sim {
namespace {

// Delays within one period of the default 23 MHz (43.5 ns), amplitudes within 1:5, like the
// direct and indirect returns of a room.
constexpr double kMinDelay = 3e-9, kMaxDelay = 40e-9;
constexpr double kMinAmplitude = 0.03, kMaxAmplitude = 0.15;  // times brightness

class SparseScene : public Scene {
 public:
  SparseScene(const SimulatorOptions& options, const CameraInfo& camera)
      : k_(options.sparse_k),
        seed_(options.seed),
        brightness_(options.brightness),
        geometry_(camera.geometry) {}

  int max_returns() const override { return k_; }

  void Render(double /*time_s*/, ReturnPlanes* out) const override {
    out->Reset(geometry_, k_);
    Random random({seed_, kStreamScene});
    for (int64_t p = 0; p < geometry_.pixel_count(); ++p) {
      for (int r = 0; r < k_; ++r) {
        const int64_t i = out->index(r, p);
        out->tau_s[i] = static_cast<float>(random.Uniform(kMinDelay, kMaxDelay));
        out->amplitude[i] =
            static_cast<float>(brightness_ * random.Uniform(kMinAmplitude, kMaxAmplitude));
      }
    }
    out->SortByDelay();
  }

 private:
  int k_;
  uint64_t seed_;
  double brightness_;
  ImageGeometry geometry_;
};

}  // namespace

std::unique_ptr<Scene> MakeSparseScene(const SimulatorOptions& options, const CameraInfo& camera) {
  return std::make_unique<SparseScene>(options, camera);
}

}  // namespace transient::sim
