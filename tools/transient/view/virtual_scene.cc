#include "tools/transient/view/virtual_scene.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "transient/reconstruct/camera_model.h"
#include "transient/reconstruct/vec3.h"

namespace transient::tools {
namespace {


// The backdrop's viewer sees a wider field than the camera (focal lengths times this), so the
// whole backdrop fits with some margin.
constexpr double kViewerZoom = 0.9;
constexpr int kPlaneChecks = 8;  // checks across the plane's width

// The rectangle of a VirtualPlane in the optical frame: corners a + s (b - a) + t (0, 1, 0),
// s in [0, 1], |t| <= half_height.
struct PlaneGeometry {
  Vec3 a, b, normal;
  double half_height = 0.0;
  double length = 0.0;  // |b - a|
};

PlaneGeometry GeometryOf(const VirtualPlane& plane, const MomentSetup& setup) {
  const PinholeIntrinsics& k = setup.intrinsics;
  const double mean_depth = 0.5 * (plane.left_depth_m + plane.right_depth_m);
  const double middle_row = 0.5 * (setup.geometry.height - 1);
  const double y = (middle_row - k.cy) / k.fy * mean_depth;
  PlaneGeometry g;
  g.a = {(plane.left_column - k.cx) / k.fx * plane.left_depth_m, y, plane.left_depth_m};
  g.b = {(plane.right_column - k.cx) / k.fx * plane.right_depth_m, y, plane.right_depth_m};
  const Vec3 e = g.b - g.a;
  g.length = e.norm();
  g.normal = Vec3{-e.z, 0.0, e.x} * (1.0 / g.length);  // e x (0, 1, 0)
  g.half_height = 0.5 * plane.height_fraction * setup.geometry.height / k.fy * mean_depth;
  return g;
}

// Where the ray origin + lambda dir (lambda > 0) meets the rectangle: the point and its (s, t).
bool HitPlane(const PlaneGeometry& g, const Vec3& origin, const Vec3& dir, Vec3* point, double* s,
              double* t) {
  const double denominator = g.normal.dot(dir);
  if (std::abs(denominator) < 1e-12) return false;
  const double lambda = g.normal.dot(g.a - origin) / denominator;
  if (!(lambda > 0.0)) return false;
  *point = origin + dir * lambda;
  *s = (*point - g.a).dot(g.b - g.a) / (g.length * g.length);
  *t = point->y - g.a.y;
  return *s >= 0.0 && *s <= 1.0 && std::abs(*t) <= g.half_height;
}

Rgb8 Shade(Rgb8 colour, double lambert) {
  const double f = 0.45 + 0.55 * std::clamp(lambert, 0.0, 1.0);
  return {static_cast<uint8_t>(std::lround(colour.r * f)),
          static_cast<uint8_t>(std::lround(colour.g * f)),
          static_cast<uint8_t>(std::lround(colour.b * f))};
}

// Camera coordinates of output pixel U at `upscale` output pixels per camera pixel.
double CameraCoordinate(int output, int upscale) { return (output + 0.5) / upscale - 0.5; }

Fragments EmptyFragments(const MomentSetup& setup) {
  Fragments f;
  f.geometry = setup.output_geometry();
  const size_t n = static_cast<size_t>(f.geometry.pixel_count());
  f.depth_m.assign(n, kNaNf);
  f.x.assign(n, kNaNf);
  f.y.assign(n, kNaNf);
  return f;
}

// Camera rays through every output pixel: fills x, y and calls hit(p, dir) for the rest.
template <typename Hit>
Fragments CastFromCamera(const MomentSetup& setup, Hit hit) {
  Fragments f = EmptyFragments(setup);
  f.colour.assign(f.depth_m.size(), Rgb8{});
  const PinholeIntrinsics& k = setup.intrinsics;
  const int width = f.geometry.width;
  for (int v = 0; v < f.geometry.height; ++v) {
    for (int u = 0; u < width; ++u) {
      const size_t p = static_cast<size_t>(v) * width + u;
      const double x = CameraCoordinate(u, setup.upscale);
      const double y = CameraCoordinate(v, setup.upscale);
      f.x[p] = static_cast<float>(x);
      f.y[p] = static_cast<float>(y);
      const Vec3 dir = PixelRay(k, x, y);
      double depth = 0.0;
      Rgb8 colour;
      if (hit(dir, &depth, &colour)) {
        f.depth_m[p] = static_cast<float>(depth);
        f.colour[p] = colour;
      }
    }
  }
  return f;
}

}  // namespace

Fragments RenderPlane(const MomentSetup& setup) {
  const PlaneGeometry g = GeometryOf(setup.plane, setup);
  const double check = g.length / kPlaneChecks;
  return CastFromCamera(setup, [&](const Vec3& dir, double* depth, Rgb8* colour) {
    Vec3 point;
    double s = 0.0, t = 0.0;
    if (!HitPlane(g, {}, dir, &point, &s, &t)) return false;
    *depth = point.z;
    const int i = static_cast<int>(std::floor(s * kPlaneChecks));
    const int j = static_cast<int>(std::floor((t + g.half_height) / check));
    const double lambert = std::abs(g.normal.dot(dir)) / dir.norm();
    *colour = Shade((i + j) % 2 == 0 ? kPlaneColourA : kPlaneColourB, lambert);
    return true;
  });
}

Fragments RenderSphere(const MomentSetup& setup) {
  const PinholeIntrinsics& k = setup.intrinsics;
  const double z = setup.sphere.depth_m, r = setup.sphere.radius_m;
  const Vec3 centre{(setup.sphere.column - k.cx) / k.fx * z, (setup.sphere.row - k.cy) / k.fy * z,
                    z};
  return CastFromCamera(setup, [&](const Vec3& dir, double* depth, Rgb8* colour) {
    // |lambda dir - centre| = r, nearest root (the camera is outside the sphere: Z > R).
    const double a = dir.dot(dir), b = dir.dot(centre), c = centre.dot(centre) - r * r;
    const double discriminant = b * b - a * c;
    if (discriminant < 0.0) return false;
    const double lambda = (b - std::sqrt(discriminant)) / a;
    if (!(lambda > 0.0)) return false;
    const Vec3 point = dir * lambda;
    *depth = point.z;
    const Vec3 normal = (point - centre) * (1.0 / r);
    *colour = Shade(kSphereColour, -normal.dot(dir) / std::sqrt(a));
    return true;
  });
}

Fragments RenderBackdrop(const MomentSetup& setup) {
  Fragments f = EmptyFragments(setup);
  const PlaneGeometry g = GeometryOf(setup.backdrop, setup);
  const PinholeIntrinsics& k = setup.intrinsics;
  // The viewer at (offset, 0, 0) looks at the backdrop's centre, turned about the y axis only.
  const Vec3 viewer{setup.viewpoint_offset_m, 0.0, 0.0};
  const Vec3 centre = (g.a + g.b) * 0.5;
  const double dx = centre.x - viewer.x, dz = centre.z - viewer.z;
  const double length = std::hypot(dx, dz);
  const Vec3 forward{dx / length, 0.0, dz / length};
  const Vec3 right{forward.z, 0.0, -forward.x};
  const Vec3 down{0.0, 1.0, 0.0};
  const int width = f.geometry.width;
  for (int v = 0; v < f.geometry.height; ++v) {
    for (int u = 0; u < width; ++u) {
      const double xv = CameraCoordinate(u, setup.upscale);
      const double yv = CameraCoordinate(v, setup.upscale);
      const Vec3 dir = right * ((xv - k.cx) / (kViewerZoom * k.fx)) +
                       down * ((yv - k.cy) / (kViewerZoom * k.fy)) + forward;
      Vec3 point;
      double s = 0.0, t = 0.0;
      if (!HitPlane(g, viewer, dir, &point, &s, &t) || !(point.z > 0.0)) continue;
      // Its projection into the camera, the light's shadow map; outside it nothing is known.
      const double x = k.fx * point.x / point.z + k.cx;
      const double y = k.fy * point.y / point.z + k.cy;
      if (!(x >= -0.5 && x <= setup.geometry.width - 0.5 && y >= -0.5 &&
            y <= setup.geometry.height - 0.5)) {
        continue;
      }
      const size_t p = static_cast<size_t>(v) * width + u;
      f.depth_m[p] = static_cast<float>(point.z);
      f.x[p] = static_cast<float>(x);
      f.y[p] = static_cast<float>(y);
    }
  }
  return f;
}

}  // namespace transient::tools
