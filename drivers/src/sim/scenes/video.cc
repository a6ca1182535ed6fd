// The `video` scene (thesis fig. 8.14): a person made of a sphere and boxes walks to and fro in
// front of a diffuse wall that is also lit via a mirror on the right. Pixels get up to two
// Dirac returns (direct and via the mirror); the person occludes both the view and the light
// paths, so shadows move with them. The scene is a pure function of time.
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <numbers>

#include "../geometry.h"
#include "../scene.h"

namespace transient::sim {
namespace {

constexpr double kWallZ = 3.0;
constexpr double kWallAlbedo = 0.8;
constexpr double kPersonAlbedo = 0.5;
constexpr double kMirrorX = 2.6;  // outside the field of view at the wall
constexpr double kMirrorNearZ = 0.5, kMirrorHalfHeight = 1.5;
constexpr double kMirrorReflectance = 0.9;
constexpr double kPersonZ = 2.0;        // m, walking parallel to the wall
constexpr double kWalkAmplitude = 1.2;  // m either side of the optical axis
constexpr double kWalkPeriod = 6.0;     // s for there and back: 0.8 m/s
constexpr double kStridePeriod = 1.0;   // s per double step
const Vec3 kLight{0.1, 0.0, 0.0};

struct Box {
  Vec3 lo, hi;
};
struct Sphere {
  Vec3 centre;
  double radius;
};

// The person at one time: head, torso and two legs.
struct Person {
  Sphere head;
  std::array<Box, 3> boxes;
};

Person PersonAt(double t) {
  const double phase = std::fmod(t / kWalkPeriod, 1.0);
  const double x = kWalkAmplitude * (phase < 0.5 ? 4.0 * phase - 1.0 : 3.0 - 4.0 * phase);
  const double stride = 0.12 * std::sin(2.0 * std::numbers::pi * t / kStridePeriod);
  Person person;
  person.head = {{x, -0.55, kPersonZ}, 0.11};
  person.boxes[0] = {{x - 0.2, -0.42, kPersonZ - 0.12}, {x + 0.2, 0.2, kPersonZ + 0.12}};
  person.boxes[1] = {{x - 0.16 + stride, 0.2, kPersonZ - 0.07},
                     {x - 0.03 + stride, 1.0, kPersonZ + 0.07}};
  person.boxes[2] = {{x + 0.03 - stride, 0.2, kPersonZ - 0.07},
                     {x + 0.16 - stride, 1.0, kPersonZ + 0.07}};
  return person;
}

// Nearest positive hit distance of a ray with a box (slab method) and its outward normal.
double HitBox(const Box& box, const Vec3& origin, const Vec3& dir, Vec3* normal) {
  double t_near = -INFINITY, t_far = INFINITY;
  int axis = 0;
  const double o[3] = {origin.x, origin.y, origin.z}, d[3] = {dir.x, dir.y, dir.z};
  const double lo[3] = {box.lo.x, box.lo.y, box.lo.z}, hi[3] = {box.hi.x, box.hi.y, box.hi.z};
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-15) {
      if (o[a] < lo[a] || o[a] > hi[a]) return INFINITY;
      continue;
    }
    double t0 = (lo[a] - o[a]) / d[a], t1 = (hi[a] - o[a]) / d[a];
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > t_near) {
      t_near = t0;
      axis = a;
    }
    t_far = std::min(t_far, t1);
  }
  if (t_near > t_far || t_near <= 1e-9) return INFINITY;
  if (normal != nullptr) {
    double n[3] = {0.0, 0.0, 0.0};
    n[axis] = d[axis] > 0.0 ? -1.0 : 1.0;
    *normal = {n[0], n[1], n[2]};
  }
  return t_near;
}

double HitSphere(const Sphere& s, const Vec3& origin, const Vec3& dir, Vec3* normal) {
  const Vec3 oc = origin - s.centre;
  const double b = oc.dot(dir), c = oc.dot(oc) - s.radius * s.radius;
  const double disc = b * b - c;
  if (disc < 0.0) return INFINITY;
  const double t = -b - std::sqrt(disc);
  if (t <= 1e-9) return INFINITY;
  if (normal != nullptr) *normal = ((origin + dir * t) - s.centre) * (1.0 / s.radius);
  return t;
}

// Nearest hit with the person along a unit ray; +inf when none.
double HitPerson(const Person& person, const Vec3& origin, const Vec3& dir, Vec3* normal) {
  Vec3 n;
  double best = HitSphere(person.head, origin, dir, &n);
  if (normal != nullptr && std::isfinite(best)) *normal = n;
  for (const Box& box : person.boxes) {
    const double t = HitBox(box, origin, dir, &n);
    if (t < best) {
      best = t;
      if (normal != nullptr) *normal = n;
    }
  }
  return best;
}

// Whether the segment a -> b passes through the person.
bool Blocked(const Person& person, const Vec3& a, const Vec3& b) {
  const Vec3 d = b - a;
  const double length = d.norm();
  return HitPerson(person, a, d * (1.0 / length), nullptr) < length - 1e-6;
}

class VideoScene : public Scene {
 public:
  VideoScene(const SimulatorOptions& options, const CameraInfo& camera)
      : brightness_(options.brightness), camera_(camera) {}

  int max_returns() const override { return 2; }
  bool dynamic() const override { return true; }

  void Render(double time_s, ReturnPlanes* out) const override {
    const ImageGeometry g = camera_.geometry;
    out->Reset(g, 2);
    const Person person = PersonAt(time_s);
    const Vec3 mirror_normal{1.0, 0.0, 0.0};
    const Vec3 image = Reflect(kLight, mirror_normal, kMirrorX);
#pragma omp parallel for schedule(dynamic, 4) if (g.pixel_count() > 50000)
    for (int v = 0; v < g.height; ++v) {
      for (int u = 0; u < g.width; ++u) {
        const int64_t p = int64_t{v} * g.width + u;
        const Vec3 ray = PixelRay(camera_, u, v);
        Vec3 normal{0.0, 0.0, -1.0};
        double albedo = kWallAlbedo;
        double t = kWallZ / ray.z;
        const double t_person = HitPerson(person, {}, ray, &normal);
        if (t_person < t) {
          t = t_person;
          albedo = kPersonAlbedo;
        } else {
          normal = {0.0, 0.0, -1.0};
        }
        const Vec3 point = ray * t;
        int r = 0;
        auto add = [&](const Vec3& source, double strength, double length) {
          const double signal =
              DiffuseSignal(brightness_ * strength, albedo, source, point, normal);
          if (signal <= 0.0) return;
          const int64_t i = out->index(r++, p);
          out->tau_s[i] = static_cast<float>(Delay(length + t));
          out->amplitude[i] = static_cast<float>(signal);
        };
        if (!Blocked(person, point, kLight)) add(kLight, 1.0, (point - kLight).norm());
        // Via the mirror: the image source's path must cross the mirror, and neither leg of
        // the real path may pass through the person.
        const double s = (kMirrorX - image.x) / (point.x - image.x);
        const Vec3 hit = image + (point - image) * s;
        if (s > 0.0 && s < 1.0 && hit.z >= kMirrorNearZ && hit.z <= kWallZ &&
            std::abs(hit.y) <= kMirrorHalfHeight && !Blocked(person, point, hit) &&
            !Blocked(person, hit, kLight)) {
          add(image, kMirrorReflectance, (point - image).norm());
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

std::unique_ptr<Scene> MakeVideoScene(const SimulatorOptions& options, const CameraInfo& camera) {
  return std::make_unique<VideoScene>(options, camera);
}

}  // namespace transient::sim
