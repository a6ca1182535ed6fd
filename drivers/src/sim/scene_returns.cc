// Public access to a scene's per-pixel returns (scene_returns.h) over the simulator internals.
#include "transient/drivers/scene_returns.h"

#include <cmath>
#include <memory>

#include "absl/strings/str_cat.h"
#include "geometry.h"
#include "scene.h"

namespace transient {

Complex SceneReturnCharacteristicFunction(const SceneReturn& r, double omega) {
  Complex value = std::polar(std::exp(-0.5 * r.sigma_s * r.sigma_s * omega * omega),
                             omega * r.tau_s);
  if (r.decay_rate > 0.0) value /= Complex(1.0, -omega / r.decay_rate);
  return value;
}

absl::StatusOr<SceneReturns> RenderSceneReturns(const SimulatorOptions& options, double time_s) {
  if (!std::isfinite(time_s) || time_s < 0.0) {
    return absl::InvalidArgumentError(
        absl::StrCat("time_s = ", time_s, ". Violated constraint: time_s >= 0"));
  }
  // The simulator builds its camera from the options; opening it is the one public way to get
  // exactly that camera, so the rays here are the rays the scene was rendered with.
  absl::StatusOr<std::unique_ptr<CaptureSource>> source = OpenSimulator(options);
  if (!source.ok()) return source.status();
  SceneReturns out;
  out.camera = (*source)->camera();
  absl::StatusOr<std::unique_ptr<sim::Scene>> scene = sim::MakeScene(options, out.camera);
  if (!scene.ok()) return scene.status();
  sim::ReturnPlanes planes;
  (*scene)->Render(time_s, &planes);
  planes.SortByDelay();
  const int64_t pixels = planes.geometry.pixel_count();
  out.offsets.reserve(pixels + 1);
  out.offsets.push_back(0);
  for (int64_t p = 0; p < pixels; ++p) {
    for (int r = 0; r < planes.max_returns; ++r) {
      const int64_t i = planes.index(r, p);
      if (!(planes.amplitude[i] > 0.0f)) continue;
      out.returns.push_back({planes.tau_s[i], planes.amplitude[i], planes.sigma_s[i],
                             planes.decay_rate[i]});
    }
    out.offsets.push_back(static_cast<int64_t>(out.returns.size()));
  }
  return out;
}

std::array<double, 3> CameraRay(const CameraInfo& camera, int u, int v) {
  const sim::Vec3 ray = sim::PixelRay(camera, u, v);
  return {ray.x, ray.y, ray.z};
}

}  // namespace transient
