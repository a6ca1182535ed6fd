// A 3-D vector of doubles for the little geometry the project does: camera rays, the
// simulator's planes and mirrors, virtual objects in front of the camera. Lengths in metres in
// the optical frame of the camera (x right, y down, z forward; DESIGN.md).
#pragma once

#include <cmath>

namespace transient {

struct Vec3 {
  double x = 0.0, y = 0.0, z = 0.0;
  Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  double dot(const Vec3& o) const { return x * o.x + y * o.y + z * o.z; }
  Vec3 cross(const Vec3& o) const {
    return {y * o.z - z * o.y, z * o.x - x * o.z, x * o.y - y * o.x};
  }
  double norm() const { return std::sqrt(dot(*this)); }
  Vec3 normalized() const { return *this * (1.0 / norm()); }
};

}  // namespace transient
