// The `corner` scene, the range benchmark of thesis fig. 8.13: a diffuse 90-degree corner in
// front of the camera, both walls lit by a source beside the camera. Each pixel gets a Dirac
// (the direct path) and a continuous return (one diffuse bounce off the other wall), integrated
// over patches of the other wall at open time and summarized by an exponentially modified
// Gaussian with the same total light, mean, variance and skew (method of moments).
#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>

#include "../geometry.h"
#include "../scene.h"

namespace transient::sim {
namespace {

constexpr double kEdgeZ = 2.0;       // the vertical edge of the corner is at x = 0, z = 2 m
constexpr double kWallLength = 1.6;  // of each wall from the edge, m (beyond the field of view)
constexpr double kHalfHeight = 1.2;  // m
constexpr double kAlbedo = 0.7;
constexpr int kPatchesAlong = 32, kPatchesUp = 24;  // per wall; the indirect light is smooth
constexpr double kMinSigma = 0.05e-9;  // s, keeps the EMG a density where the fit degenerates
const Vec3 kLight{0.05, 0.0, 0.0};

const double kInvSqrt2 = 1.0 / std::sqrt(2.0);

struct Wall {
  Vec3 normal;    // unit, towards the camera
  Vec3 along;     // unit, from the edge outwards
  double offset;  // normal . x = offset on the wall
};

Wall LeftWall() {  // z - x = kEdgeZ for x <= 0
  return {{kInvSqrt2, 0.0, -kInvSqrt2}, {-kInvSqrt2, 0.0, -kInvSqrt2}, -kEdgeZ * kInvSqrt2};
}
Wall RightWall() {  // z + x = kEdgeZ for x >= 0
  return {{-kInvSqrt2, 0.0, -kInvSqrt2}, {kInvSqrt2, 0.0, -kInvSqrt2}, -kEdgeZ * kInvSqrt2};
}

struct Patch {
  Vec3 centre;
  double flux;   // (albedo/pi) * irradiance from the source * area: radiance times area
  double delay;  // source to patch, s
};

class CornerScene : public Scene {
 public:
  CornerScene(const SimulatorOptions& options, const CameraInfo& camera)
      : brightness_(options.brightness), camera_(camera) {
    for (int w = 0; w < 2; ++w) {
      const Wall wall = w == 0 ? LeftWall() : RightWall();
      const Vec3 edge{0.0, 0.0, kEdgeZ};
      const double du = kWallLength / kPatchesAlong, dv = 2.0 * kHalfHeight / kPatchesUp;
      for (int a = 0; a < kPatchesAlong; ++a) {
        for (int b = 0; b < kPatchesUp; ++b) {
          const Vec3 centre =
              edge + wall.along * ((a + 0.5) * du) + Vec3{0.0, -kHalfHeight + (b + 0.5) * dv, 0.0};
          // DiffuseSignal with brightness 1 is the irradiance relative to the source intensity.
          const double irradiance = DiffuseSignal(1.0, 1.0, kLight, centre, wall.normal);
          patches_[w].push_back({centre, kAlbedo / std::numbers::pi * irradiance * du * dv,
                                 Delay((centre - kLight).norm())});
        }
      }
    }
  }

  int max_returns() const override { return 2; }

  void Render(double /*time_s*/, ReturnPlanes* out) const override {
    const ImageGeometry g = camera_.geometry;
    out->Reset(g, 2);
#pragma omp parallel for schedule(dynamic, 4) if (g.pixel_count() > 50000)
    for (int v = 0; v < g.height; ++v) {
      for (int u = 0; u < g.width; ++u) RenderPixel(u, v, out);
    }
  }

 private:
  void RenderPixel(int u, int v, ReturnPlanes* out) const {
    const int64_t p = int64_t{v} * camera_.geometry.width + u;
    const Vec3 ray = PixelRay(camera_, u, v);
    // The walls meet at the edge; the nearer intersection is the visible one.
    const int w = ray.x < 0.0 ? 0 : 1;
    const Wall wall = w == 0 ? LeftWall() : RightWall();
    const double t = RayPlane({}, ray, wall.normal, wall.offset);
    if (!std::isfinite(t)) return;
    const Vec3 point = ray * t;
    if (std::abs(point.y) > kHalfHeight) return;  // above or below the walls: nothing returns
    const double back = t;
    const double direct_delay = Delay((point - kLight).norm() + back);
    const int64_t d = out->index(0, p);
    out->tau_s[d] = static_cast<float>(direct_delay);
    out->amplitude[d] =
        static_cast<float>(DiffuseSignal(brightness_, kAlbedo, kLight, point, wall.normal));

    // One bounce off the other wall: light and its first three delay moments.
    const Wall& other = w == 0 ? RightWall() : LeftWall();
    double weight = 0.0, m1 = 0.0, m2 = 0.0, m3 = 0.0;
    for (const Patch& patch : patches_[1 - w]) {
      const Vec3 to_patch = patch.centre - point;
      const double r2 = std::max(to_patch.dot(to_patch), 1e-4);
      const double r = std::sqrt(r2);
      const double cos_point = wall.normal.dot(to_patch) / r;
      const double cos_patch = -other.normal.dot(to_patch) / r;
      if (cos_point <= 0.0 || cos_patch <= 0.0) continue;
      const double light = patch.flux * cos_point * cos_patch / r2;
      const double delay = patch.delay + Delay(r) + Delay(back) - direct_delay;
      weight += light;
      m1 += light * delay;
      m2 += light * delay * delay;
      m3 += light * delay * delay * delay;
    }
    if (weight <= 0.0) return;
    const double mean = m1 / weight;
    const double variance = std::max(m2 / weight - mean * mean, 0.0);
    const double third = m3 / weight - 3.0 * mean * variance - mean * mean * mean;
    // EMG: mean = mu + 1/lambda, variance = sigma^2 + 1/lambda^2, third = 2/lambda^3.
    double tail = third > 0.0 ? std::cbrt(0.5 * third) : 0.0;
    tail = std::min({tail, 0.95 * std::sqrt(variance), mean});  // onset after the direct path
    const double sigma = std::max(std::sqrt(std::max(variance - tail * tail, 0.0)), kMinSigma);
    const int64_t i = out->index(1, p);
    out->tau_s[i] = static_cast<float>(direct_delay + mean - tail);
    out->amplitude[i] = static_cast<float>(brightness_ * kAlbedo * weight);
    out->sigma_s[i] = static_cast<float>(sigma);
    out->decay_rate[i] = tail > 0.0 ? static_cast<float>(1.0 / tail) : 0.0f;
  }

  double brightness_;
  CameraInfo camera_;
  std::vector<Patch> patches_[2];
};

}  // namespace

std::unique_ptr<Scene> MakeCornerScene(const SimulatorOptions& options, const CameraInfo& camera) {
  return std::make_unique<CornerScene>(options, camera);
}

}  // namespace transient::sim
