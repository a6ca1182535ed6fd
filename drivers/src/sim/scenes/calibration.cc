// The `calibration` scene (thesis fig. 8.3): the light source points into the sensor through a
// neutral density filter and a diffuser, so every pixel sees a Dirac at time of flight zero.
#include <memory>

#include "../scene.h"

namespace transient::sim {
namespace {

// Share of `brightness` at the centre and its fall-off towards the corners: the diffuser's
// light is uniform-ish, never flat, so calibrations cannot rely on equal brightness.
constexpr double kCentre = 0.25;
constexpr double kFalloff = 0.3;

class CalibrationScene : public Scene {
 public:
  CalibrationScene(const SimulatorOptions& options, const CameraInfo& camera)
      : brightness_(options.brightness), camera_(camera) {}

  int max_returns() const override { return 1; }

  void Render(double /*time_s*/, ReturnPlanes* out) const override {
    const ImageGeometry g = camera_.geometry;
    out->Reset(g, 1);
    const double half_w = 0.5 * g.width, half_h = 0.5 * g.height;
    for (int v = 0; v < g.height; ++v) {
      for (int u = 0; u < g.width; ++u) {
        const double dx = (u - camera_.intrinsics.cx) / half_w,
                     dy = (v - camera_.intrinsics.cy) / half_h;
        const double r2 = 0.5 * (dx * dx + dy * dy);  // 1 in the corners
        const int64_t i = out->index(0, int64_t{v} * g.width + u);
        out->tau_s[i] = 0.0f;
        out->amplitude[i] = static_cast<float>(brightness_ * kCentre * (1.0 - kFalloff * r2));
      }
    }
  }

 private:
  double brightness_;
  CameraInfo camera_;
};

}  // namespace

std::unique_ptr<Scene> MakeCalibrationScene(const SimulatorOptions& options,
                                            const CameraInfo& camera) {
  return std::make_unique<CalibrationScene>(options, camera);
}

}  // namespace transient::sim
