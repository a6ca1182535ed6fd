// The `mirrors` scene (thesis fig. 8.7): a diffuse wall lit directly and via two side mirrors,
// so that light sweeps over the wall three times. Image-source method: each mirror contributes
// the light of the source mirrored in its plane, where the path crosses the finite mirror.
#include <algorithm>
#include <cmath>
#include <memory>

#include "../geometry.h"
#include "../scene.h"

namespace transient::sim {
namespace {

// Geometry (metres). The mirrors stand perpendicular to the wall outside the field of view, at
// different distances, so that the three path lengths of every wall point differ by at least
// 0.6 m (2 ns, 0.29 rad at 23 MHz) and the longest stays below one period of 23 MHz (13 m):
// the returns stay separable by Pisarenko with m = 3 (checked by the tests).
constexpr double kWallZ = 2.0;
constexpr double kWallAlbedo = 0.8;
constexpr double kRightMirrorX = 2.0;
constexpr double kLeftMirrorX = -3.8;
constexpr double kMirrorNearZ = 0.2, kMirrorFarZ = kWallZ;
constexpr double kMirrorHalfHeight = 1.0;
constexpr double kMirrorReflectance = 0.9;
const Vec3 kLight{0.1, 0.0, 0.0};  // next to the camera, towards the near (right) mirror
// The source has a batwing diffuser: intensity ~ 1/cos^3 of the angle to the optical axis (a
// plane facing it is lit uniformly), capped. The mirrors, seen at grazing angles, then pass on
// light comparable to the direct return instead of a few percent of it.
constexpr double kMaxBatwing = 8.0;

double Batwing(const Vec3& direction) {
  const double cosine = direction.z / direction.norm();
  return cosine <= 0.0 ? 0.0 : std::min(1.0 / (cosine * cosine * cosine), kMaxBatwing);
}

class MirrorsScene : public Scene {
 public:
  MirrorsScene(const SimulatorOptions& options, const CameraInfo& camera)
      : brightness_(options.brightness), camera_(camera) {}

  int max_returns() const override { return 3; }

  void Render(double /*time_s*/, ReturnPlanes* out) const override {
    const ImageGeometry g = camera_.geometry;
    out->Reset(g, max_returns());
    const Vec3 wall_normal{0.0, 0.0, -1.0};  // facing the camera
    for (int v = 0; v < g.height; ++v) {
      for (int u = 0; u < g.width; ++u) {
        const int64_t p = int64_t{v} * g.width + u;
        const Vec3 ray = PixelRay(camera_, u, v);
        const Vec3 point = ray * (kWallZ / ray.z);
        const double back = point.norm();  // wall to camera
        int r = 0;
        // `strength`: reflectance and beam profile along the path's first leg.
        auto add = [&](const Vec3& source, double strength) {
          const double signal =
              DiffuseSignal(brightness_ * strength, kWallAlbedo, source, point, wall_normal);
          if (signal <= 0.0) return;
          const int64_t i = out->index(r++, p);
          out->tau_s[i] = static_cast<float>(Delay((point - source).norm() + back));
          out->amplitude[i] = static_cast<float>(signal);
        };
        add(kLight, Batwing(point - kLight));
        for (double mirror_x : {kRightMirrorX, kLeftMirrorX}) {
          const Vec3 normal{1.0, 0.0, 0.0};
          const Vec3 image = Reflect(kLight, normal, mirror_x);
          // The segment image -> point must cross the mirror plane inside the mirror.
          const double t = (mirror_x - image.x) / (point.x - image.x);
          const Vec3 hit = image + (point - image) * t;
          if (t > 0.0 && t < 1.0 && hit.z >= kMirrorNearZ && hit.z <= kMirrorFarZ &&
              std::abs(hit.y) <= kMirrorHalfHeight) {
            add(image, kMirrorReflectance * Batwing(hit - kLight));
          }
        }
      }
    }
    out->SortByDelay();
  }

 private:
  double brightness_;
  CameraInfo camera_;
};

}  // namespace

std::unique_ptr<Scene> MakeMirrorsScene(const SimulatorOptions& options, const CameraInfo& camera) {
  return std::make_unique<MirrorsScene>(options, camera);
}

}  // namespace transient::sim
