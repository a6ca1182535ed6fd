// Small 3-D vector geometry shared by the scenes: camera rays, planes, mirror images and the
// radiometry of a diffuse surface lit by a point source. Camera at the origin, optical frame
// x right, y down, z forward (DESIGN.md), lengths in metres.
#pragma once

#include <cmath>

#include "transient/drivers/capture_source.h"
#include "transient/reconstruct/camera_model.h"
#include "transient/reconstruct/moments.h"
#include "transient/reconstruct/vec3.h"

namespace transient::sim {

using ::transient::Vec3;

// Unit direction of the ray through the centre of pixel (column u, row v), pinhole model.
inline Vec3 PixelRay(const CameraInfo& camera, int u, int v) {
  return ::transient::PixelRay(camera.intrinsics, u, v);
}

// Distance along `direction` from `origin` to the plane {x : n.x = offset}; +inf when the ray
// is parallel to or points away from it.
inline double RayPlane(const Vec3& origin, const Vec3& direction, const Vec3& n, double offset) {
  const double denominator = n.dot(direction);
  if (std::abs(denominator) < 1e-12) return INFINITY;
  const double t = (offset - n.dot(origin)) / denominator;
  return t > 0.0 ? t : INFINITY;
}

// Mirror image of `point` in the plane {x : n.x = offset} (n unit): the image source of the
// image-source method.
inline Vec3 Reflect(const Vec3& point, const Vec3& n, double offset) {
  return point - n * (2.0 * (n.dot(point) - offset));
}

// Delay of a path of total length `length_m`.
inline double Delay(double length_m) { return length_m / kSpeedOfLight; }

// Electrons per second a pixel collects from a Lambertian point of `albedo` with unit normal
// `normal`, lit by an isotropic point source at `light`: `brightness` is the value for a white
// surface lit head-on at 1 m. Independent of the viewing distance (the pixel's footprint grows
// as fast as the radiance falls); zero when lit from behind.
inline double DiffuseSignal(double brightness, double albedo, const Vec3& light, const Vec3& point,
                            const Vec3& normal) {
  const Vec3 to_light = light - point;
  const double d2 = to_light.dot(to_light);
  const double cosine = normal.dot(to_light) / std::sqrt(d2);
  return cosine > 0.0 ? brightness * albedo * cosine / d2 : 0.0;
}

}  // namespace transient::sim
