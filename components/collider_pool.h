// Every collider the solver knows, as one list of collider kinds in structure of arrays: the
// ground plane and static spheres today, meshes next. A contact names its collider by index into
// this list, so the contact kernels dispatch on `shape` once per contact, never on a hard-coded
// pair of special cases. Static lifetime: rebuilt when the world's colliders change.
#pragma once

#include <cstdint>
#include <vector>

#include "nucleon/types.h"

namespace nucleon {

enum class ColliderShape : std::uint8_t {
  Plane,   // the half-space below `point` along `normal` is solid
  Sphere,  // the ball of `radius` about `point` is solid
};

struct ColliderPool {
  std::vector<ColliderShape> shape;
  std::vector<Vec3> point;  // a point on the plane, or the sphere's centre
  std::vector<Vec3>
      normal;  // the plane's unit normal, pointing out of the solid; unused for spheres
  std::vector<Real> radius;  // the sphere's radius; 0 for planes
  // Particles stay this far outside the surface (the collider's share of the contact distance).
  std::vector<Real> thickness;
  std::vector<Real> friction;        // Coulomb μ_k (sliding)
  std::vector<Real> staticFriction;  // Coulomb μ_s (sticking)

  std::size_t size() const { return shape.size(); }
  void clear() {
    shape.clear(), point.clear(), normal.clear(), radius.clear(), thickness.clear();
    friction.clear(), staticFriction.clear();
  }
  void append(ColliderShape s, const Vec3& at, const Vec3& n, Real r, Real surfaceThickness,
              Real kineticMu, Real staticMu) {
    shape.push_back(s);
    point.push_back(at);
    normal.push_back(n);
    radius.push_back(r);
    thickness.push_back(surfaceThickness);
    friction.push_back(kineticMu);
    staticFriction.push_back(staticMu);
  }
};

}  // namespace nucleon
